"""LIGGGHTS 3.8 as a `dempath_sim.runs.Backend`: a dempath scene in, a :class:`SimResult` out.

``LiggghtsBackend(workdir).run(scene)`` writes and runs the fill deck, picks the markers and
candidates on the settled LIGGGHTS bed with dempath's own rules (``markers.select_markers``),
places the tool at the scene's depth below the settled surface, writes and runs the tool deck,
and reads the tracked dump and the tool force file into the same record the dempath engine
returns. Differences from the dempath engine are listed in ``docs/liggghts.md``.
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from dempath.dumpio import frames_by_id, read_dump, read_print
from dempath_sim.effects import PhysicsModel
from dempath_sim.engine.mesh import TriangleMesh
from dempath_sim.engine.params import SimParams
from dempath_sim.engine.state import SimState
from dempath_sim.engine.stl import read_stl
from dempath_sim.engine.timestep import rayleigh_time_step
from dempath_sim.errors import RunStoppedError, SceneError
from dempath_sim.liggghts import fill_deck as fd
from dempath_sim.liggghts import tool_deck as td
from dempath_sim.liggghts.commands import write_ascii_stl
from dempath_sim.liggghts.errors import DeckError
from dempath_sim.liggghts.runner import RunOutput, run_deck
from dempath_sim.runs.backend import RunOptions
from dempath_sim.runs.bed.fill import fill_bed
from dempath_sim.runs.bed.measure import measure
from dempath_sim.runs.bed.placement import removal_mask
from dempath_sim.runs.bed.pour import pour, target_solid_fraction
from dempath_sim.runs.identity import run_identity
from dempath_sim.runs.markers import select_markers
from dempath_sim.runs.physics import PARTICLES, build_params
from dempath_sim.runs.results import SimResult
from dempath_sim.scene.profiles import ToolPath
from dempath_sim.scene.spec import SceneSpec

logger = logging.getLogger(__name__)
Box = tuple[list[float], list[float]]  # (lo, hi) corners of the simulation box [m]


def scene_time_step(scene: SceneSpec, model: PhysicsModel) -> float:
    """The scene's time step, or rayleigh_safety x the Rayleigh step of the finest sphere [s]."""
    if scene.sim.time_step_s is not None:
        return scene.sim.time_step_s
    d_min = min(min(fd.layer_templates(layer, model.coarse_grain if layer.coarse_grained
                                       else 1.0)[0]) for layer in scene.layers)
    shear = model.particle_youngs_modulus_pa / (2 * (1 + model.particle_poisson))
    nu = model.particle_poisson
    dt_r = math.pi * d_min / 2 * math.sqrt(model.particle_density_kg_m3 / shear) / (
        0.1631 * nu + 0.8766)
    return scene.sim.rayleigh_safety * dt_r


@dataclass(frozen=True)
class SettledBed:
    """The LIGGGHTS bed after the fill: ids (n,), positions (n, 3) m, radii (n,) m, report,
    the step number it ended on."""

    step: int
    ids: NDArray[np.int64]
    positions: NDArray[np.float64]
    radii: NDArray[np.float64]
    report: dict[str, float]
    run: RunOutput


POURS = ('dempath', 'insert')  # loose bed of the LIGGGHTS fill: dempath's pour or insert/pack
FRICTIONS = ('static', 'dynamic')  # dempath coefficient used as LIGGGHTS' single friction


def dempath_time_step(params: SimParams, state: SimState) -> float:
    """The step dempath's engine takes on ``state``: params.dt or safety x Rayleigh step [s]."""
    if params.dt is not None:
        return params.dt
    return params.rayleigh_safety * rayleigh_time_step(state.radii, state.material, params)


def _pour_deck(scene: SceneSpec, params: SimParams, workdir: Path, friction: str,
               ) -> tuple[str, float, NDArray[np.int32], Box]:
    """dempath's loose pour of the seed as ``pour.data``; the deck, dt [s], layer per id - 1,
    the box."""
    model = scene.physics_model()
    loose = pour(scene, model, params)
    dt = dempath_time_step(params, loose)
    big = 2.0 * float(loose.radii.max())
    top = float((loose.positions[:, 1] + loose.radii).max())
    box = fd.box_bounds(scene, top, 2 * big, tool_sweep(scene, model))
    order = np.argsort(loose.ids)
    fd.write_data(str(workdir / fd.POUR_DATA), loose.ids[order].astype(np.int64) + 1,
                  loose.positions[order], loose.velocities[order],
                  loose.angular_velocities[order], loose.radii[order],
                  model.particle_density_kg_m3, len(params.materials), box)
    text = fd.pour_fill_deck(scene, params, dt, 0.3 * big, friction=friction)
    return text, dt, np.asarray(loose.extra['layer'], dtype=np.int32)[order], box


def _insert_deck(scene: SceneSpec, params: SimParams, friction: str,
                 ) -> tuple[str, float, fd.FillPlan, Box]:
    """The insert/pack fill deck, its dt [s] (dividing the output interval), plan and box."""
    model = scene.physics_model()
    dt0 = scene_time_step(scene, model)
    dt = scene.output.interval_s / max(1, math.ceil(scene.output.interval_s / dt0))
    plan = fd.fill_plan(scene, model.coarse_grain, target_solid_fraction(scene, model))
    extent = tool_sweep(scene, model)
    text = fd.insert_fill_deck(scene, params, dt, plan, friction, extent)
    big = max(max(d) for d in plan.diameters)
    return text, dt, plan, fd.box_bounds(scene, plan.top, 2 * big, extent)


def fill_liggghts(scene: SceneSpec, workdir: Path, nprocs: int = 1,
                  friction: str = 'static', pour_from: str = 'dempath') -> SettledBed:
    """Write and run ``in.fill``; return the settled bed and its surface/bulk-density report.

    Args:
        scene: The scene.
        workdir: Directory for the deck, data file, log and dumps.
        nprocs: MPI processes.
        friction: LIGGGHTS' Coulomb coefficient ('static' or 'dynamic').
        pour_from: ``'dempath'``: settle dempath's loose pour of the seed (same particles,
            positions, velocities and time step as the dempath fill); ``'insert'``: LIGGGHTS
            inserts its own loose bed with ``fix insert/pack``.
    """
    if pour_from not in POURS:
        msg = f'pour_from: must be one of {POURS}, got {pour_from!r}'
        raise DeckError(msg)
    model = scene.physics_model()
    params = build_params(scene, model)
    workdir.mkdir(parents=True, exist_ok=True)
    if pour_from == 'dempath':
        text, dt, layer_of, box = _pour_deck(scene, params, workdir, friction)
        expected = len(layer_of)
    else:
        text, dt, plan, box = _insert_deck(scene, params, friction)
        expected = sum(plan.counts)
    (workdir / 'in.fill').write_text(text)
    run = run_deck(workdir / 'in.fill', nprocs=nprocs)
    frame = read_dump(workdir / fd.FILL_DUMP)[-1]
    ids = frame.column('id').astype(np.int64)
    pos = frame.data[:, [frame.columns.index(c) for c in ('x', 'y', 'z')]]
    radii = frame.column('radius')
    cols = [frame.columns.index(c) for c in ('vx', 'vy', 'vz', 'omegax', 'omegay', 'omegaz')]
    fd.write_data(str(workdir / fd.BED_DATA), ids, pos, frame.data[:, cols[:3]],
                  frame.data[:, cols[3:]], radii, model.particle_density_kg_m3,
                  len(params.materials), box)
    if len(ids) < 0.99 * expected:
        logger.warning('liggghts fill: %d of %d particles in the bed (see %s)', len(ids),
                       expected, run.log_path)
    state = SimState.from_spheres(pos, radii, PARTICLES, params, ids=ids)
    if pour_from == 'dempath':
        state.extra['layer'] = layer_of[ids - 1].astype(np.int32)
    else:
        state.extra['layer'] = np.where(radii >= 0.999 * min(plan.diameters[-1]) / 2,
                                        len(scene.layers) - 1, 0).astype(np.int32)
    report = {**measure(scene, model, state), 'n_particles': float(len(ids)), 'dt_s': dt,
              'settle_time_s': frame.step * dt, 'pour_from_dempath': float(pour_from == 'dempath')}
    logger.info('liggghts fill: %d particles, surface %.4f m, bulk density %.0f kg/m^3',
                len(ids), report['surface_height_m'], report['bulk_density_kg_m3'])
    return SettledBed(frame.step, ids, pos, radii, report, run)


def slot_ids(bed: SettledBed, triangles: NDArray[np.float64], placement: str = 'slot',
             name: str = 'tool') -> NDArray[np.int64]:
    """Ids of the particles the tool (world ``triangles``) displaces at its start, by dempath's
    rule for ``placement`` (``runs.bed.placement``: carve or bounding-box slot)."""
    mesh = TriangleMesh(np.asarray(triangles, dtype=np.float64), name=name)
    return bed.ids[removal_mask(bed.positions, bed.radii, mesh, (0.0, 0.0, 0.0), placement)]


def tool_sweep(scene: SceneSpec, model: PhysicsModel,
               slack_m: float = 0.1) -> tuple[list[float], list[float]]:
    """Bounding box (lo, hi) [m] the tool sweeps during the pass, with ``slack_m`` in Y for the
    unknown settled surface (the fill box must contain it; see deck.box_bounds)."""
    verts = read_stl(scene.tool.mesh).reshape(-1, 3) * scene.tool.scale
    path = tool_path(scene, model, 0.0)
    start = np.asarray(path.start_position_m)
    lo = verts.min(axis=0) + start
    hi = verts.max(axis=0) + start
    hi[2] += scene.tool.travel_m
    lo[1] -= slack_m
    hi[1] += slack_m
    return lo.tolist(), hi.tolist()


def tool_path(scene: SceneSpec, model: PhysicsModel, surface_y: float) -> ToolPath:
    """Tip path: depth below the settled (or nominal, shifted) surface, profile x speed_scale."""
    tool = scene.tool
    if tool.depth_reference == 'settled_surface':
        y = surface_y - tool.depth_m
    else:
        y = -tool.depth_m + tool.settling_offset_m
    profile = tool.profile.scaled(model.speed_scale) if model.speed_scale != 1.0 else tool.profile
    return ToolPath(profile, (tool.x_m, y, tool.start_z_m), tool.profile_offset_m)


def bed_from_packing(scene: SceneSpec, state: SimState, surface_y: float,
                     workdir: Path) -> SettledBed:
    """A dempath packing as the LIGGGHTS bed: ``bed.data`` (LIGGGHTS ids = dempath ids + 1)."""
    model = scene.physics_model()
    dt = dempath_time_step(build_params(scene, model), state)
    workdir.mkdir(parents=True, exist_ok=True)
    box = fd.box_bounds(scene, 0.0, 4 * float(state.radii.max()), tool_sweep(scene, model))
    ids = state.ids.astype(np.int64) + 1
    fd.write_data(str(workdir / fd.BED_DATA), ids, state.positions, state.velocities,
                  state.angular_velocities, state.radii, model.particle_density_kg_m3, 3, box)
    report = {'surface_height_m': surface_y, 'n_particles': float(state.n), 'dt_s': dt,
              'from_dempath_packing': 1.0}
    return SettledBed(0, ids, state.positions.copy(), state.radii.copy(), report,
                      RunOutput(workdir, workdir / 'bed.data', 0.0, 0.0, 1))


FILLS = ('shared_pour', 'insert_pack', 'shared_packing')  # how LIGGGHTS gets its bed


class LiggghtsBackend:
    """LIGGGHTS 3.8 as a `Backend`: fill, place markers and the tool, run the pass, read back.

    The constructor only stores the settings (no I/O); LIGGGHTS is looked for when a run starts.

    Args:
        workdir: Directory for decks, logs and dumps (kept for inspection).
        nprocs: MPI processes.
        friction: Which dempath friction coefficient LIGGGHTS uses ('static' or 'dynamic').
        fill: How LIGGGHTS gets its bed. ``'shared_pour'``: it settles dempath's loose pour of
            the seed (``runs.bed.pour``) with its own physics; ``'insert_pack'``: it pours its
            own loose bed with ``fix insert/pack``; ``'shared_packing'``: it starts from
            dempath's settled packing (``runs.bed.fill_bed`` with ``options.cache_dir``;
            tracked ids are then dempath ids + 1).

    Raises:
        ValueError: ``nprocs`` < 1, or ``friction`` or ``fill`` unknown.
    """

    name = 'liggghts'

    def __init__(self, workdir: str | Path, nprocs: int = 1, friction: str = 'static',
                 fill: str = 'shared_pour') -> None:
        for field, value, allowed in (('friction', friction, FRICTIONS), ('fill', fill, FILLS)):
            if value not in allowed:
                msg = f'LiggghtsBackend.{field}: must be one of {allowed}, got {value!r}'
                raise ValueError(msg)
        if nprocs < 1:
            msg = f'LiggghtsBackend.nprocs: must be >= 1, got {nprocs!r}'
            raise ValueError(msg)
        self.workdir, self.nprocs = Path(workdir), nprocs
        self.friction, self.fill = friction, fill

    def run(self, scene: SceneSpec, options: RunOptions | None = None) -> SimResult:
        """Run ``scene`` on LIGGGHTS. Of ``options`` it uses ``cache_dir`` (shared_packing),
        ``follow_s`` (the tool stands still after its travel while the bed is followed) and
        ``stop`` (checked before the fill and before the pass); LIGGGHTS runs as a
        subprocess, so there are no frames and no progress. The whole bed is dumped every
        ``output.snapshot_interval_s`` (``snapshot_*`` of the result, with the radii).

        Raises:
            LiggghtsNotFoundError: LIGGGHTS or mpirun missing.
            SceneError: ``tool.placement: poured`` with a fill other than shared_packing.
            LiggghtsRunError: A LIGGGHTS run failed (names the log).
            DumpError: A dump is missing or malformed.
            RunStoppedError: ``options.stop`` was set before the pass.
        """
        options = options or RunOptions()
        if scene.tool.placement == 'poured' and self.fill != 'shared_packing':
            msg = (f'{scene.source}: tool.placement: poured: the LIGGGHTS backend pours its bed '
                   f"without the tool (fill {self.fill!r}); run it with fill 'shared_packing' "
                   "(dempath's bed poured around the tool) or set tool.placement: carve")
            raise SceneError(msg)
        _check_stop(options, 'fill')
        packing = None
        if self.fill == 'shared_packing':
            model = scene.bed_model()
            state, report = fill_bed(scene, model, build_params(scene, model), options.cache_dir)
            packing = (state, report.surface_height_m)
        pour_from = 'insert' if self.fill == 'insert_pack' else 'dempath'
        return _run_scene(scene, self.workdir, self.nprocs, self.friction, packing, pour_from,
                          options)


def _check_stop(options: RunOptions, phase: str) -> None:
    if options.stop is not None and options.stop.is_set():
        msg = f'LIGGGHTS run stopped before the {phase} (no output yet)'
        raise RunStoppedError(msg)


def _run_scene(scene: SceneSpec, workdir: Path, nprocs: int, friction: str,
               packing: tuple[SimState, float] | None, pour_from: str,
               options: RunOptions) -> SimResult:
    """Fill (or take ``packing`` and its surface height [m]), pick markers, run the pass."""
    model = scene.physics_model()
    if packing is None:
        bed = fill_liggghts(scene, workdir, nprocs, friction, pour_from)
    else:
        bed = bed_from_packing(scene, packing[0], packing[1], workdir)
    sel = select_markers(bed.positions, bed.radii, bed.ids, scene.markers)
    ids, roles, marker_ids = sel.tracked(scene.output.candidates)
    path = tool_path(scene, model, bed.report['surface_height_m'])
    tris = read_stl(scene.tool.mesh) * scene.tool.scale + np.asarray(path.start_position_m)
    write_ascii_stl(str(workdir / td.TOOL_STL), tris.tolist(), 'tool')
    slot = slot_ids(bed, tris, scene.tool.placement, str(scene.tool.mesh))
    dt = bed.report['dt_s']
    every = round(scene.output.interval_s / dt)
    snap = round(scene.output.snapshot_interval_s / dt)
    travel = path.time_to_travel(scene.tool.travel_m)
    stop = travel if options.follow_s > 0 else math.inf
    stage = td.ToolStage(path, ids, 0, slot, travel + options.follow_s, dt, every, snap,
                         settle_steps=round(scene.tool.settle_s / dt), stop_s=stop)
    params = build_params(scene, model)
    (workdir / 'in.tool').write_text(td.tool_deck(scene, params, stage, friction))
    _check_stop(options, 'pass')
    t0 = time.monotonic()
    run = run_deck(workdir / 'in.tool', nprocs=nprocs)
    meta = {'end_time_s': travel, 'drive_wall_s': time.monotonic() - t0}
    return _result(workdir, stage, ids, roles, marker_ids, bed, run, scene, meta)


def _result(workdir: Path, stage: td.ToolStage, ids: NDArray[np.int64],
            roles: NDArray[np.uint8], marker_ids: NDArray[np.int32], bed: SettledBed,
            run: RunOutput, scene: SceneSpec, extra: dict[str, float]) -> SimResult:
    frames = read_dump(workdir / td.TRACKED_DUMP)
    data = frames_by_id(frames, ids, ('x', 'y', 'z', 'vx', 'vy', 'vz'))
    times = (np.array([f.step for f in frames], dtype=np.float64) - stage.start_step) * stage.dt
    tool = read_print(workdir / td.TOOL_FILE, 10)
    force = np.zeros((len(times), 9))
    k = np.searchsorted(times, tool[:, 0] - 0.5 * stage.dt)
    ok = k < len(times)
    force[k[ok]] = tool[ok, 1:]
    force[0, 6:] = stage.path.start_position_m
    radius_of = dict(zip(bed.ids.tolist(), bed.radii.tolist(), strict=True))
    meta = {**run_identity(scene).as_meta(), 'engine': 'liggghts',
            'fill': bed.report, 'dt_s': stage.dt, 'nprocs': run.nprocs,
            'fill_loop_time_s': bed.run.loop_time_s, 'pass_loop_time_s': run.loop_time_s,
            'workdir': str(workdir), 'run_id': f'{scene.name}-s{scene.seed}-liggghts', **extra}
    snap_times, snaps = _snapshots(workdir, stage, bed.ids)
    return SimResult(times=times, ids=ids, roles=roles, marker_ids=marker_ids,
                     radii=np.array([radius_of[int(i)] for i in ids]),
                     positions=data[..., :3], velocities=data[..., 3:],
                     tool_position=force[:, 6:9], tool_force=force[:, 0:3],
                     tool_torque=force[:, 3:6], snapshot_times=snap_times,
                     snapshot_ids=bed.ids.astype(np.int64), snapshot_positions=snaps,
                     snapshot_radii=bed.radii.astype(np.float64), meta=meta)


def _snapshots(workdir: Path, stage: td.ToolStage, bed_ids: NDArray[np.int64],
               ) -> tuple[NDArray[np.float64], NDArray[np.float32]]:
    """(ns,) times [s] and (ns, N, 3) float32 positions of the whole-bed dump (NaN where a
    particle is gone: the tool's slot, lost from the box); empty without snapshots."""
    path = workdir / td.SNAPSHOT_DUMP
    if not stage.snapshot_every or not path.is_file():
        return np.zeros(0), np.zeros((0, len(bed_ids), 3), np.float32)
    frames = read_dump(path)
    times = (np.array([f.step for f in frames], np.float64) - stage.start_step) * stage.dt
    return times, frames_by_id(frames, bed_ids, ('x', 'y', 'z')).astype(np.float32)
