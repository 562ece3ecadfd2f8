"""The native backend: a scene end to end on dempath's engine -> SimResult.

`NativeBackend` implements `runs.backend.Backend`; :func:`run_scene` is the same run as a function
(the CLI and the node call it); :func:`run_batch` runs several effect settings and seeds one after
the other on any backend (the engine already uses every core). Steps: build the engine parameters
from the scene's physics model; fill the bin or read the cached packing; pick markers and
candidates; insert the tool at its depth (``tool.placement``: the particles overlapping its closed
mesh are removed, or those in its bounding box, see ``runs.bed.placement``); re-settle the bed with
the tool in place and the run's own physics for ``tool.settle_s`` (so that the pass starts with the
contact history of a bed at rest against the tool, as a LIGGGHTS deck's re-settle does, also when
the packing came from the cache or was poured with the scene file's physics); then drive the tool
with the profile in the same engine and record the tracked particles, the tool pose, force and
torque every ``output.interval_s`` and the whole bed every ``output.snapshot_interval_s``.
Deterministic for a given seed on one machine and thread count.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dempath_sim.effects import PhysicsModel
from dempath_sim.engine import Engine, SimParams, SimState, ToolPose, TriangleMesh
from dempath_sim.engine.sleep import SleepSettings
from dempath_sim.errors import RunStoppedError, SimulationError
from dempath_sim.runs.backend import Backend, Frame, Progress, RunOptions
from dempath_sim.runs.bed import FillReport, fill_bed, place_tool, tool_start
from dempath_sim.runs.bed.placement import carve_tool_slot
from dempath_sim.runs.identity import run_id, run_identity
from dempath_sim.runs.markers import MarkerSelection, select_markers
from dempath_sim.runs.physics import TOOL, bin_walls, build_params
from dempath_sim.runs.rest import RestWatch
from dempath_sim.runs.results import Recorder, SimResult
from dempath_sim.runs.shared_settle import load_settled, save_settled, settled_file
from dempath_sim.scene.profiles import ToolPath
from dempath_sim.scene.spec import SceneSpec

logger = logging.getLogger(__name__)

def pass_start_springs(engine: Engine) -> int:
    """Particle pairs whose tangential spring is loaded when the pass starts (the contact
    history the re-settle built; 0 for a pass started on a bed without history)."""
    return engine.loaded_springs


def _with_run_masses(state: SimState, params: SimParams) -> SimState:
    """The bed with masses from the run's particle density (the bed's physics may differ)."""
    fresh = SimState.from_spheres(state.positions, state.radii, state.material, params,
                                  velocities=state.velocities, ids=state.ids)
    fresh.angular_velocities[:] = state.angular_velocities
    fresh.extra = dict(state.extra)
    return fresh


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
    removed_by_tool: int = 0
    rest_at_s: float | None = None  # the follow ended here, the bed at rest (runs.rest)

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
    state, removed = place_tool(state, mesh, start, scene.tool.placement)
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
    engine = Engine(params, bin_walls(scene), mesh,
                    sleep=SleepSettings().scaled(scene.sim.sleep_scale) if scene.sim.sleep
                    else None)
    engine.tool_pose = ToolPose(*path.pose_at(0.0))
    engine.bind(state)
    dt = float(engine.dt or 0.0)
    steps = max(1, round(scene.output.interval_s / dt))
    per_snap = max(1, round(scene.output.snapshot_interval_s / (steps * dt)))
    recorder = Recorder(ids, roles, marker_ids, radii, state.ids.copy(), state.radii.copy())
    drive = _Drive(engine, path, recorder, selection, path.time_to_travel(scene.tool.travel_m),
                   steps, per_snap, removed_by_tool=removed)
    return drive, state


def resettle(drive: _Drive, state: SimState, duration_s: float) -> SimState:
    """Settle the bed against the tool standing at its start (the run's engine and physics).

    The same engine then drives the tool, so the pass starts with the springs this builds;
    the state's clock is set back to 0 for the pass.
    """
    engine = drive.engine
    engine.tool_pose = ToolPose(np.asarray(drive.path.pose_at(0.0)[0]), np.zeros(3))
    steps = round(duration_s / float(engine.dt or 1.0))
    if steps:
        state = engine.run(state, steps)
    logger.info('re-settle with the tool in place: %d steps (%.3f s), %d particle contacts',
                steps, state.time, engine.n_contacts)
    state.time, state.step = 0.0, 0
    engine.tool_pose = drive.pose(0.0)
    return state


def settled_start(drive: _Drive, state: SimState, scene: SceneSpec,
                  options: RunOptions) -> tuple[SimState, bool]:
    """The bed at the start of the pass and whether it was shared: resumed from the kept
    re-settled bed of the run's settle key (``options.shared_settle``, when the cache holds
    one) or re-settled here (`resettle`)."""
    if options.shared_settle:
        path = settled_file(scene, options.cache_dir)
        data = load_settled(path)
        if data is not None:
            engine = drive.engine
            state = engine.resume(data)
            state.time, state.step = 0.0, 0
            engine.tool_force = np.array(data['run.tool_force'], np.float64).reshape(3)
            engine.tool_torque = np.array(data['run.tool_torque'], np.float64).reshape(3)
            engine.tool_pose = drive.pose(0.0)
            logger.info('re-settled bed shared: resumed from %s', path.name)
            return state, True
    return resettle(drive, state, scene.tool.settle_s), False


def keep_settled(scene: SceneSpec, cache_dir: Path | None = None) -> bool:
    """Re-settle the bed of a pass of ``scene`` once and keep it in the packing cache for the
    runs that share its settle key (``RunOptions.shared_settle``); True if made here.

    Raises:
        SimulationError: The set-up is unstable.
    """
    path = settled_file(scene, cache_dir)
    if path.is_file():
        return False
    model, bed = scene.physics_model(), scene.bed_model()
    params = build_params(scene, model)
    state, report = fill_bed(scene, bed, build_params(scene, bed), cache_dir)
    drive, state = _prepare_drive(scene, params, model, _with_run_masses(state, params), report)
    state = resettle(drive, state, scene.tool.settle_s)
    engine = drive.engine
    save_settled(path, engine.checkpoint(state),
                 {'tool_force': engine.tool_force, 'tool_torque': engine.tool_torque})
    return True


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
    """Move the tool to the end of its travel, recording every output interval.

    With ``options.rest_tolerance_m`` the follow after the tool stops ends once the bed is at
    rest (`RestWatch`); the frames left are recorded from the last state without stepping.
    """
    t0 = time.monotonic()
    drive.record(state, options)
    _progress(options, 'drive', state.time, drive.end_time_s, t0)  # bar names the phase at once
    frame_s = drive.steps_per_frame * (drive.engine.dt or 1.0)
    n_frames = math.ceil(drive.end_time_s / frame_s)
    if options.follow_s > 0.0:
        drive.stop_time_s = n_frames * frame_s
        n_frames += math.ceil(options.follow_s / frame_s)
    watch = RestWatch(options.rest_tolerance_m) if options.rest_tolerance_m > 0.0 else None
    for k in range(n_frames):
        if options.stop is not None and options.stop.is_set():
            logger.info('run stopped at t = %.3f s', state.time)
            break
        if drive.rest_at_s is None:
            state = drive.engine.run(state, drive.steps_per_frame, drive.pose)
        else:  # at rest: the frame repeats the last state (the clock as the steps move it)
            for _ in range(drive.steps_per_frame):
                state.time += drive.engine.dt or 0.0
            state.step += drive.steps_per_frame
        drive.record(state, options)
        _progress(options, 'drive', state.time, drive.end_time_s, t0)
        if (watch is not None and drive.rest_at_s is None
                and state.time >= drive.stop_time_s - 0.5 * frame_s
                and watch.at_rest(state.ids, state.positions, n_frames - 1 - k)):
            drive.rest_at_s = state.time
            logger.info('bed at rest at t = %.3f s (largest step %.2g m a frame): the %d '
                        'frames left repeat it', state.time, watch.last_step_m, n_frames - 1 - k)
    return state


class NativeBackend:
    """dempath's own engine as a `Backend` (no settings: threads follow numba's)."""

    name = 'dempath'

    def run(self, scene: SceneSpec, options: RunOptions | None = None) -> SimResult:
        """`run_scene` (honours every option: cache, progress, frames, stop)."""
        return run_scene(scene, options)


def run_scene(scene: SceneSpec, options: RunOptions | None = None) -> SimResult:
    """Run ``scene`` end to end on dempath's engine and return the tracked trajectories.

    Raises:
        SimulationError: The set-up is unstable or a marker has no particle near it.
        RunStoppedError: ``options.stop`` was set during the fill.
        GeometryError: The tool's STL cannot be read.
    """
    options = options or RunOptions()
    model = scene.physics_model()
    params = build_params(scene, model)
    bed = scene.bed_model()
    t_fill = time.monotonic()
    state, report = fill_bed(scene, bed, build_params(scene, bed), options.cache_dir,
                             progress=_fill_progress(options, t_fill))
    state = _with_run_masses(state, params)
    fill_wall = time.monotonic() - t_fill
    drive, state = _prepare_drive(scene, params, model, state, report)
    t_settle = time.monotonic()
    state, shared = settled_start(drive, state, scene, options)
    springs = pass_start_springs(drive.engine)
    evals_settle = drive.engine.pair_evaluations
    t_drive = time.monotonic()
    state = drive_tool(drive, state, options)
    meta: dict[str, Any] = {
        **run_identity(scene).as_meta(), 'engine': 'dempath', 'source': scene.source,
        'effects': scene.to_dict()['effects'], 'fill': asdict(report),
        'dt_s': drive.engine.dt, 'n_particles': state.n,
        'removed_particles': drive.engine.removed_count, 'end_time_s': drive.end_time_s,
        'sim_time_s': state.time, 'fill_wall_s': fill_wall,
        'placement': scene.tool.placement, 'removed_by_tool': drive.removed_by_tool,
        'resettle_s': scene.tool.settle_s, 'resettle_wall_s': t_drive - t_settle,
        'settle_shared': shared,
        'pass_start_springs': springs, 'bed_physics': scene.fill.physics,
        'drive_wall_s': time.monotonic() - t_drive,
        'sleep': scene.sim.sleep, 'resettle_pair_evaluations': evals_settle,
        'drive_pair_evaluations': drive.engine.pair_evaluations - evals_settle,
        'asleep_at_end': drive.engine.n_asleep, 'woken': drive.engine.woken,
        'rest_at_s': drive.rest_at_s,
        'grid_points': drive.selection.grid_points.tolist()}
    result = drive.recorder.result(meta)
    meta['warnings'] = run_warnings(result.tool_force, report)
    for warning in meta['warnings']:
        logger.warning('%s: %s', scene.name, warning)
    return result


SPARSE_SOLID_FRACTION = 0.3  # a settled bed of spheres holds 0.55-0.64; below this it is no bed
SHALLOW_FRACTION = 0.5  # a surface lower than this fraction of the bed thickness: no bed


def run_warnings(tool_force: NDArray[np.float64], report: FillReport) -> list[str]:
    """What makes a finished run's answer meaningless although it ran: a bed far too sparse to
    be a settled soil (e.g. a packing file of a hundred spheres) or a tool that met no particle
    (draft 0 N over the whole pass).

    Args:
        tool_force: (nt, 3) force on the tool [N].
        report: The fill report of the bed.
    """
    warnings = []
    depth = -report.floor_y_m  # nominal bed thickness: the surface is at Y = 0
    shallow = report.surface_height_m - report.floor_y_m < (1.0 - SHALLOW_FRACTION) * depth
    if report.solid_fraction < SPARSE_SOLID_FRACTION or shallow:
        warnings.append(f'the bed ({report.source}) holds {report.n_particles} particles at solid '
                        f'fraction {report.solid_fraction:.3f} with its surface '
                        f'{-report.surface_height_m * 1e3:.0f} mm below the nominal one; a '
                        'settled bed holds 0.55-0.64 up to the surface, so this is not the soil '
                        'the scene describes')
    if not np.any(np.abs(tool_force) > 0.0):
        warnings.append('the tool met no particle: the draft force is 0 N over the whole pass '
                        '(check the bed, the tool depth and its start)')
    return warnings


@dataclass(frozen=True)
class Variant:
    """One effect setting of a batch: parameter overrides and effects switched off / on."""

    label: str
    values: Mapping[str, float] = field(default_factory=dict)
    off: tuple[str, ...] = ()
    on: tuple[str, ...] = ()


def run_batch(scene: SceneSpec, variants: Sequence[Variant], seeds: Sequence[int] = (),
              options: RunOptions | None = None,
              backend: Backend | None = None) -> list[tuple[Variant, int, SimResult]]:
    """Run every variant with every seed (the scene's seed if none), one after the other.

    Packings are shared through the cache, so variants that change only the tool or its speed
    skip the fill. ``backend``: `NativeBackend()` if None. Returns (variant, seed, result) in
    the order run.
    """
    backend = backend or NativeBackend()
    out = []
    for variant in variants:
        for seed in (seeds or (scene.seed,)):
            changed = scene.with_overrides(variant.values, off=variant.off, on=variant.on,
                                           seed=seed)
            logger.info('batch: %s seed %d', variant.label, seed)
            out.append((variant, seed, backend.run(changed, options)))
    return out


__all__ = [
    'NativeBackend',
    'RunStoppedError',
    'SimulationError',
    'Variant',
    'carve_tool_slot',
    'keep_settled',
    'pass_start_springs',
    'resettle',
    'run_batch',
    'run_id',
    'run_scene',
    'run_warnings',
    'settled_start',
    'tool_start',
]
