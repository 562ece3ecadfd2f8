"""Running a scene end to end: fill (or cached packing), tool, drive, record -> SimResult.

:func:`run_scene` is the batch API (the CLI, the node and the diagnosis call it);
:func:`run_batch` runs several effect settings and seeds one after the other (the engine already
uses every core). Steps: build the engine parameters from the scene's physics model; fill the
bin or read the cached packing; pick markers and candidates; insert the tool at its depth (the
particles inside the tool's bounding box at its start are removed, as if the tool stood in a
pre-cut slot); drive it with the profile and record the tracked particles, the tool pose, force
and torque every ``output.interval_s`` and the whole bed every ``output.snapshot_interval_s``.
Deterministic for a given seed on one machine and thread count.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from threading import Event
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dempath_sim.effects import ContactPair, PhysicsModel
from dempath_sim.engine import Engine, ToolPose
from dempath_sim.errors import RunStoppedError, SimulationError
from dempath_sim.fill import PARTICLES, TOOL, WALLS, FillReport, bin_walls, fill_bed
from dempath_sim.markers import MarkerSelection, select_markers
from dempath_sim.materials import Interaction, Material
from dempath_sim.mesh import TriangleMesh
from dempath_sim.params import SimParams
from dempath_sim.profiles import ToolPath
from dempath_sim.results import Recorder, SimResult
from dempath_sim.scene_spec import SceneSpec
from dempath_sim.state import SimState

logger = logging.getLogger(__name__)

DOMAIN_MARGIN_M = 0.2  # the domain box reaches this far beyond the bin walls [m]


@dataclass(frozen=True)
class Progress:
    """Progress of a run, passed to the progress callback.

    Attributes:
        phase: ``fill`` or ``drive``.
        sim_time_s: Simulated time of the phase so far [s].
        end_time_s: Simulated time at which the phase ends [s].
        wall_time_s: Wall-clock time of the phase so far [s].
    """

    phase: str
    sim_time_s: float
    end_time_s: float
    wall_time_s: float

    @property
    def real_time_factor(self) -> float:
        """Simulated seconds per wall-clock second (> 1: faster than real time)."""
        return self.sim_time_s / self.wall_time_s if self.wall_time_s > 0 else 0.0


@dataclass(frozen=True)
class Frame:
    """One output frame for streaming consumers (the node).

    Attributes:
        t: Time since the tool started [s].
        ids, roles, marker_ids, radii: (n,) of the tracked particles.
        positions, velocities: (n, 3) [m], [m/s]; NaN when removed.
        tool_position, tool_velocity, tool_force, tool_torque: (3,) [m], [m/s], [N], [N m].
    """

    t: float
    ids: NDArray[np.int64]
    roles: NDArray[np.uint8]
    marker_ids: NDArray[np.int32]
    radii: NDArray[np.float64]
    positions: NDArray[np.float64]
    velocities: NDArray[np.float64]
    tool_position: NDArray[np.float64]
    tool_velocity: NDArray[np.float64]
    tool_force: NDArray[np.float64]
    tool_torque: NDArray[np.float64]


@dataclass(frozen=True)
class RunOptions:
    """How to run (not what): cache, callbacks and cancellation.

    Attributes:
        cache_dir: Packing cache; the default cache if None.
        progress: Called with a Progress about every output interval.
        on_frame: Called with each output Frame (streaming consumers).
        stop: Set it to stop the run early: during the drive the result holds the frames so
            far; during the fill `RunStoppedError` is raised at the next settling check.
        follow_s: Time to go on recording after the tool has stopped at the end of its travel
            (the bed still moves) [s]; the tool stays where it stopped.
    """

    cache_dir: Path | None = None
    progress: Callable[[Progress], None] | None = None
    on_frame: Callable[[Frame], None] | None = None
    stop: Event | None = field(default=None, compare=False)
    follow_s: float = 0.0


def _interaction(pair: ContactPair) -> Interaction:
    return Interaction(restitution=pair.restitution, static_friction=pair.static_friction,
                       dynamic_friction=pair.dynamic_friction,
                       rolling_friction=pair.rolling_resistance,
                       cohesion_energy_density=pair.cohesion_energy_density_j_m3)


def build_params(scene: SceneSpec, model: PhysicsModel) -> SimParams:
    """Engine parameters: materials PARTICLES, WALLS, TOOL and their three interactions."""
    walls = scene.materials['walls']
    materials = (
        Material('particles', model.particle_density_kg_m3, model.particle_youngs_modulus_pa,
                 model.particle_poisson),
        Material('walls', walls.density_kg_m3, model.wall_youngs_modulus_pa, model.wall_poisson),
        Material('tool', model.tool_density_kg_m3, model.tool_youngs_modulus_pa,
                 model.tool_poisson))
    floor = -scene.bed_thickness_m
    w, m = scene.bin.width_x_m / 2, DOMAIN_MARGIN_M
    return SimParams(
        materials=materials,
        interactions={(PARTICLES, PARTICLES): _interaction(model.particle_particle),
                      (PARTICLES, WALLS): _interaction(model.particle_wall),
                      (PARTICLES, TOOL): _interaction(model.particle_tool)},
        dt=scene.sim.time_step_s, rayleigh_safety=scene.sim.rayleigh_safety,
        max_overlap_fraction=scene.sim.max_overlap_fraction,
        coulomb_limit=scene.sim.coulomb_limit, contact_forms=scene.sim.contact_forms,
        domain_min=(-w - m, floor - m, -m),
        domain_max=(w + m, floor + scene.bin.height_y_m + 2.0, scene.bin.length_z_m + m))


def tool_start(scene: SceneSpec, fill: FillReport) -> tuple[float, float, float]:
    """Tip position at time 0 [m]: depth below the settled (or nominal, offset) surface."""
    tool = scene.tool
    if tool.depth_reference == 'settled_surface':
        y = fill.surface_height_m - tool.depth_m
    else:
        y = -tool.depth_m + tool.settling_offset_m
    return (tool.x_m, y, tool.start_z_m)


def carve_tool_slot(state: SimState, mesh: TriangleMesh,
                    start: tuple[float, float, float]) -> SimState:
    """Remove the particles that touch the tool's bounding box at its start position."""
    lo, hi = mesh.bounds
    lo, hi = lo + np.asarray(start), hi + np.asarray(start)
    r = state.radii[:, None]
    inside = np.all((state.positions > lo - r) & (state.positions < hi + r), axis=1)
    logger.info('tool slot: removed %d particles', int(inside.sum()))
    return state.subset(~inside)


def run_id(scene: SceneSpec) -> str:
    """Label of one run: scene name, seed and a short hash of the effect settings."""
    import hashlib
    import json

    text = json.dumps(scene.to_dict()['effects'], sort_keys=True)
    return f'{scene.name}-s{scene.seed}-{hashlib.sha256(text.encode()).hexdigest()[:8]}'


@dataclass
class _Drive:
    """The pieces of one drive: engine, tool path, recorder and the output cadence."""

    engine: Engine
    path: ToolPath
    recorder: Recorder
    selection: MarkerSelection
    end_time_s: float
    steps_per_frame: int
    frames_per_snapshot: int
    stop_time_s: float = math.inf  # the tool stands still from here on (follow after stop)

    def pose(self, t: float) -> ToolPose:
        position, velocity = self.path.pose_at(min(t, self.stop_time_s))
        return ToolPose(position, velocity if t < self.stop_time_s else 0.0 * velocity)

    def record(self, state: SimState, options: RunOptions) -> None:
        pose = self.pose(state.time)
        pos, vel = self.recorder.record(state.time, state.ids, state.positions,
                                        state.velocities, pose.position, self.engine.tool_force,
                                        self.engine.tool_torque)
        if (len(self.recorder.frames) - 1) % self.frames_per_snapshot == 0:
            self.recorder.snapshot(state.time, state.ids, state.positions)
        if options.on_frame is not None:
            r = self.recorder
            options.on_frame(Frame(state.time, r.ids, r.roles, r.marker_ids, r.radii, pos, vel,
                                   pose.position, pose.velocity, self.engine.tool_force.copy(),
                                   self.engine.tool_torque.copy()))


def _prepare_drive(scene: SceneSpec, params: SimParams, model: PhysicsModel, state: SimState,
                   report: FillReport) -> tuple[_Drive, SimState]:
    selection = select_markers(state.positions, state.radii, state.ids, scene.markers)
    mesh = TriangleMesh.from_stl(scene.tool.mesh, material=TOOL, scale=scene.tool.scale)
    start = tool_start(scene, report)
    state = carve_tool_slot(state, mesh, start)
    ids, roles, marker_ids = selection.tracked(scene.output.candidates)
    lost = np.setdiff1d(ids, state.ids)
    if len(lost):
        logger.warning('%d tracked particles lie in the tool slot and are not followed', len(lost))
    radii = np.full(len(ids), np.nan)
    order = np.argsort(state.ids)
    at = np.searchsorted(state.ids, ids, sorter=order).clip(0, state.n - 1)
    hit = state.ids[order[at]] == ids
    radii[hit] = state.radii[order[at][hit]]
    path = ToolPath(scene.tool.profile.scaled(model.speed_scale), start,
                    scene.tool.profile_offset_m)
    engine = Engine(params, bin_walls(scene), mesh)
    engine.tool_pose = ToolPose(*path.pose_at(0.0))
    engine.bind(state)
    dt = float(engine.dt or 0.0)
    steps = max(1, round(scene.output.interval_s / dt))
    per_snap = max(1, round(scene.output.snapshot_interval_s / (steps * dt)))
    drive = _Drive(engine, path, Recorder(ids, roles, marker_ids, radii, state.ids.copy()),
                   selection, path.time_to_travel(scene.tool.travel_m), steps, per_snap)
    return drive, state


def _progress(options: RunOptions, phase: str, t: float, end: float, t0: float) -> None:
    if options.progress is not None:
        options.progress(Progress(phase, t, end, time.monotonic() - t0))


def _fill_progress(options: RunOptions, t0: float) -> Callable[[float, float], None]:
    """The fill's progress callback: reports progress and honours ``options.stop``."""

    def report(t: float, end: float) -> None:
        if options.stop is not None and options.stop.is_set():
            msg = f'run stopped during the fill at t = {t:.3f} s (no output yet)'
            raise RunStoppedError(msg)
        _progress(options, 'fill', t, end, t0)

    return report


def drive_tool(drive: _Drive, state: SimState, options: RunOptions) -> SimState:
    """Move the tool to the end of its travel, recording every output interval."""
    t0 = time.monotonic()
    drive.record(state, options)
    frame_s = drive.steps_per_frame * (drive.engine.dt or 1.0)
    n_frames = math.ceil(drive.end_time_s / frame_s)
    if options.follow_s > 0.0:
        drive.stop_time_s = n_frames * frame_s
        n_frames += math.ceil(options.follow_s / frame_s)
    for _ in range(n_frames):
        if options.stop is not None and options.stop.is_set():
            logger.info('run stopped at t = %.3f s', state.time)
            break
        state = drive.engine.run(state, drive.steps_per_frame, drive.pose)
        drive.record(state, options)
        _progress(options, 'drive', state.time, drive.end_time_s, t0)
    return state


def run_scene(scene: SceneSpec, options: RunOptions | None = None) -> SimResult:
    """Run ``scene`` end to end and return the tracked trajectories.

    Raises:
        SimulationError: The set-up is unstable or a marker has no particle near it.
        RunStoppedError: ``options.stop`` was set during the fill.
        GeometryError: The tool's STL cannot be read.
    """
    options = options or RunOptions()
    model = scene.physics_model()
    params = build_params(scene, model)
    t_fill = time.monotonic()
    state, report = fill_bed(scene, model, params, options.cache_dir,
                             progress=_fill_progress(options, t_fill))
    fill_wall = time.monotonic() - t_fill
    drive, state = _prepare_drive(scene, params, model, state, report)
    t_drive = time.monotonic()
    state = drive_tool(drive, state, options)
    meta: dict[str, Any] = {
        'run_id': run_id(scene), 'scene': scene.name, 'source': scene.source, 'seed': scene.seed,
        'effects': scene.to_dict()['effects'], 'fill': asdict(report),
        'dt_s': drive.engine.dt, 'n_particles': state.n,
        'removed_particles': drive.engine.removed_count, 'end_time_s': drive.end_time_s,
        'sim_time_s': state.time, 'fill_wall_s': fill_wall,
        'drive_wall_s': time.monotonic() - t_drive,
        'grid_points': drive.selection.grid_points.tolist()}
    return drive.recorder.result(meta)


@dataclass(frozen=True)
class Variant:
    """One effect setting of a batch: parameter overrides and effects switched off / on."""

    label: str
    values: Mapping[str, float] = field(default_factory=dict)
    off: tuple[str, ...] = ()
    on: tuple[str, ...] = ()


def run_batch(scene: SceneSpec, variants: Sequence[Variant], seeds: Sequence[int] = (),
              options: RunOptions | None = None) -> list[tuple[Variant, int, SimResult]]:
    """Run every variant with every seed (the scene's seed if none), one after the other.

    Packings are shared through the cache, so variants that change only the tool or its speed
    skip the fill. Returns (variant, seed, result) in the order run.
    """
    out = []
    for variant in variants:
        for seed in (seeds or (scene.seed,)):
            changed = scene.with_overrides(variant.values, off=variant.off, on=variant.on,
                                           seed=seed)
            logger.info('batch: %s seed %d', variant.label, seed)
            out.append((variant, seed, run_scene(changed, options)))
    return out


__all__ = ['Frame', 'Progress', 'RunOptions', 'RunStoppedError', 'SimulationError', 'Variant',
           'build_params', 'run_batch', 'run_scene']
