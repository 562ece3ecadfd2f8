"""The paper's full-scale pass on dempath's engine: pour, settle, drive the chisel through 3 s.

``builtin:paper_1ms`` at full size (about 11.3 M spheres, bin 1000 x 2400 x 1020 mm, 20 mm base,
4 mm top layer; the paper's Rocky run: 86 h on a GPU). Stages, each resumable from checkpoints
in ``--work`` (an interrupted or killed run goes on from its last checkpoint):

1. **pour**: the scene's layers on jittered cubic lattices at the fill's target density, at
   rest (dempath's lattice pour; the random insert/pack pour of 11 M spheres is itself hours);
2. **settle**: the bed falls and settles under gravity until its fastest grain is slower than
   ``fill.settle_speed_m_s`` or ``--settle-max-s`` of simulated time has passed (on this pour the
   rule never fires: 4 mm fines keep falling through the 20 mm base's lattice, measured by
   ``bench/paper_pass_bound.py``, so the settle runs to ``--settle-max-s``);
3. **place**: the chisel enters at ``tool.depth_m`` below the settled surface
   (``tool.placement``, carve: the grains inside its closed mesh go), the
   markers are picked (the scene's 3 x 5 grid), and the bed re-settles against the standing
   tool for ``tool.settle_s``;
4. **drive**: the tool follows the scene's speed profile over its travel (Profile 1: 0.5 m/s^2
   to 1.0 m/s, 1.2 m, about 2.2 s) and then stands until ``--end-s`` (3 s, the paper's run);
   the markers and the tool force are recorded every ``output.interval_s``.

Grains at rest sleep (``--sleep``, default on: engine/sleep.py; ``--no-sleep`` for the plain
engine). A checkpoint (state, neighbour list, springs, sleep state, recorded tracks) is written
every ``--checkpoint-min`` minutes of wall time and at the end of each stage. Progress lines
give the stage, simulated time, steps per second, grains asleep and the estimated hours left at
the current rate. Last line: one JSON object with the wall time of each stage (this process and
earlier ones, counted up to each one's last checkpoint: the work a kill loses is not counted),
peak resident memory, and the marker statistics at the end (mean displacement of
the axis and the lateral markers, mean draft while the tool moves).

    nice -n 19 .venv/bin/python bench/paper_full_pass.py --work /tmp/paper_pass [--no-sleep]
"""

from __future__ import annotations

import argparse
import json
import logging
import math
import resource
import time
from pathlib import Path
from typing import Any

import numpy as np

from dempath_sim.engine import Engine, SimState, ToolPose, TriangleMesh
from dempath_sim.engine.sleep import SleepSettings
from dempath_sim.runs.bed import place_tool
from dempath_sim.runs.bed.measure import surface_height
from dempath_sim.runs.bed.pour import lattice_pour
from dempath_sim.runs.markers import select_markers
from dempath_sim.runs.physics import TOOL, bin_walls, build_params
from dempath_sim.scene import SceneSpec, load_scene
from dempath_sim.scene.profiles import ToolPath

log = logging.getLogger('bench')
STAGES = ('pour', 'settle', 'place', 'drive', 'done')
PAPER_ROCKY_HOURS = 86.0


def peak_rss_bytes() -> int:
    """Peak resident memory of this process so far [bytes]."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


class Work:
    """The work folder: one checkpoint file (replaced atomically) and a JSON progress record."""

    def __init__(self, folder: Path) -> None:
        """Create ``folder`` if needed and read the record left there."""
        folder.mkdir(parents=True, exist_ok=True)
        self.cp = folder / 'checkpoint.npz'
        self.rec_path = folder / 'progress.json'
        self.rec: dict[str, Any] = (json.loads(self.rec_path.read_text())
                                    if self.rec_path.is_file() else
                                    {'stage': 'pour', 'wall_s': {}, 'processes': 0})

    @property
    def stage(self) -> str:
        """The stage to run next."""
        return str(self.rec['stage'])

    def add_wall(self, stage: str, seconds: float) -> None:
        """Count ``seconds`` of wall time to ``stage``."""
        self.rec['wall_s'][stage] = self.rec['wall_s'].get(stage, 0.0) + seconds

    def save(self, arrays: dict[str, Any], stage: str, **fields: Any) -> None:
        """Write the checkpoint, then the record naming ``stage`` (a crash between the two
        leaves the older record, whose stage re-runs from the new checkpoint's content only
        if it matches: the record's stage is what is resumed)."""
        tmp = self.cp.with_name('checkpoint.tmp.npz')
        np.savez(tmp, **arrays)
        tmp.replace(self.cp)
        self.rec.update(fields, stage=stage)
        text = json.dumps(self.rec, default=float, indent=1)
        tmp_rec = self.rec_path.with_name('progress.tmp.json')
        tmp_rec.write_text(text)
        tmp_rec.replace(self.rec_path)


class Tracks:
    """Marker positions and the tool force recorded over the drive (kept in the checkpoint)."""

    def __init__(self, ids: np.ndarray, numbers: np.ndarray) -> None:
        """Follow the particles ``ids`` standing for the markers ``numbers``."""
        self.ids = ids
        self.numbers = numbers
        self.times: list[float] = []
        self.positions: list[np.ndarray] = []
        self.force: list[np.ndarray] = []

    def record(self, state: SimState, engine: Engine) -> None:
        """One output sample."""
        order = np.argsort(state.ids)
        at = order[np.searchsorted(state.ids, self.ids, sorter=order)]
        self.times.append(state.time)
        self.positions.append(state.positions[at].copy())
        self.force.append(engine.tool_force.copy())

    def arrays(self) -> dict[str, np.ndarray]:
        """The tracks as checkpoint arrays."""
        n = len(self.ids)
        return {'tracks.ids': self.ids, 'tracks.numbers': self.numbers,
                'tracks.times': np.asarray(self.times, np.float64),
                'tracks.positions': np.asarray(self.positions, np.float64).reshape(-1, n, 3),
                'tracks.force': np.asarray(self.force, np.float64).reshape(-1, 3)}

    @classmethod
    def from_arrays(cls, data: Any) -> Tracks:
        """The tracks of a checkpoint."""
        out = cls(np.array(data['tracks.ids']), np.array(data['tracks.numbers']))
        out.times = list(np.array(data['tracks.times']))
        out.positions = list(np.array(data['tracks.positions']))
        out.force = list(np.array(data['tracks.force']))
        return out


def engine_for(scene: SceneSpec, tool: bool, sleep: bool) -> Engine:
    """The engine of the scene's physics, with or without the chisel."""
    params = build_params(scene, scene.physics_model())
    mesh = TriangleMesh.from_stl(scene.tool.mesh, material=TOOL, scale=scene.tool.scale)
    return Engine(params, bin_walls(scene), mesh if tool else None,
                  sleep=SleepSettings() if sleep else None)


def saved_state(data: Any) -> SimState:
    """The particles of a checkpoint (without an engine: no neighbour list is built)."""
    fields = ('positions', 'velocities', 'angular_velocities', 'radii', 'masses', 'inertias',
              'material', 'ids')
    return SimState(*(np.array(data[f'state.{k}']) for k in fields))


def tool_path(scene: SceneSpec, start: np.ndarray) -> ToolPath:
    """The tool's path from ``start`` with the scene's profile."""
    model = scene.physics_model()
    return ToolPath(scene.tool.profile.scaled(model.speed_scale), tuple(start),
                    scene.tool.profile_offset_m)


def steps_with_checkpoints(engine: Engine, state: SimState, n_steps: int, work: Work,
                           stage: str, every_min: float, label: str,
                           motion: Any = None, per_block: int = 50,
                           extra: Any = None, on_block: Any = None) -> SimState:
    """Advance ``n_steps`` in blocks, logging progress and writing checkpoints by wall time."""
    t_last = time.monotonic()
    t_log = t_last
    done = 0
    rate_t0, rate_n0 = time.monotonic(), 0
    while done < n_steps:
        k = min(per_block, n_steps - done)
        state = engine.run(state, k, motion)
        done += k
        if on_block is not None and on_block(state, engine):
            break
        now = time.monotonic()
        if now - t_log > 60.0 or done == n_steps:
            rate = (done - rate_n0) / max(now - rate_t0, 1e-9)
            log.info('%s: t = %.4f s, step %d / %d, %.2f steps/s, %d asleep of %d, about '
                     '%.1f h left in this stage', label, state.time, done, n_steps, rate,
                     engine.n_asleep, state.n, (n_steps - done) / max(rate, 1e-9) / 3600)
            t_log = now
        if now - t_last > 60.0 * every_min:
            work.add_wall(stage, now - t_last)
            work.save({**engine.checkpoint(state), **(extra() if extra else {})}, stage)
            log.info('checkpoint written (%s, t = %.4f s)', stage, state.time)
            t_last = time.monotonic()
    work.add_wall(stage, time.monotonic() - t_last)
    return state


def run(args: argparse.Namespace) -> dict[str, Any]:
    """Every stage from where the work folder stands."""
    logging.basicConfig(level=logging.INFO, format='%(asctime)s %(message)s')
    scene = load_scene(args.scene)
    work = Work(args.work)
    work.rec['processes'] += 1
    log.info('paper pass: stage %s (process %d)', work.stage, work.rec['processes'])
    engine: Engine | None = None
    state: SimState | None = None
    tracks: Tracks | None = None
    if work.stage == 'pour':
        t0 = time.monotonic()
        model = scene.physics_model()
        state = lattice_pour(scene, model, build_params(scene, model))
        state.velocities[:] = 0.0
        engine = engine_for(scene, tool=False, sleep=args.sleep)
        engine.bind(state)
        work.add_wall('pour', time.monotonic() - t0)
        work.save(engine.checkpoint(state), 'settle', particles=state.n)
        log.info('poured %d spheres in %.0f s', state.n, time.monotonic() - t0)
    if work.stage == 'settle':
        engine = engine_for(scene, tool=False, sleep=args.sleep)
        with np.load(work.cp) as data:
            state = engine.resume(data)
        dt = float(engine.dt or 0.0)
        limit = scene.fill.settle_speed_m_s

        def settled(st: SimState, eng: Engine) -> bool:
            return float(np.sqrt((st.velocities ** 2).sum(axis=1).max())) < limit

        remaining = max(0, math.ceil(args.settle_max_s / dt) - state.step)
        state = steps_with_checkpoints(engine, state, remaining, work, 'settle',
                                       args.checkpoint_min, 'settle', on_block=settled)
        state.time, state.step = 0.0, 0
        work.save(engine.checkpoint(state), 'place', settled_s=args.settle_max_s)
    if work.stage == 'place':
        t0 = time.monotonic()
        with np.load(work.cp) as data:
            state = saved_state(data)
        surface = surface_height(scene, state)
        start = np.array([scene.tool.x_m, surface - scene.tool.depth_m, scene.tool.start_z_m])
        mesh = TriangleMesh.from_stl(scene.tool.mesh, material=TOOL, scale=scene.tool.scale)
        state, removed = place_tool(state, mesh, tuple(start), scene.tool.placement)
        selection = select_markers(state.positions, state.radii, state.ids, scene.markers)
        ids, _, numbers = selection.tracked(False)
        engine = engine_for(scene, tool=True, sleep=args.sleep)
        engine.tool_pose = ToolPose(start, np.zeros(3))
        steps = round(scene.tool.settle_s / float(engine.time_step(state)))
        state = engine.run(state, steps)
        state.time, state.step = 0.0, 0
        tracks = Tracks(ids, numbers)
        work.add_wall('place', time.monotonic() - t0)
        work.save({**engine.checkpoint(state), **tracks.arrays()}, 'drive',
                  surface_m=surface, tool_start_m=start.tolist(), removed_by_tool=removed)
    if work.stage == 'drive':
        engine = engine_for(scene, tool=True, sleep=args.sleep)
        with np.load(work.cp) as data:
            state = engine.resume(data)
            tracks = Tracks.from_arrays(data)
        start = np.asarray(work.rec['tool_start_m'])
        path = tool_path(scene, start)
        stop = path.time_to_travel(scene.tool.travel_m)
        dt = float(engine.dt or 0.0)
        per_out = max(1, round(scene.output.interval_s / dt))

        def motion(t: float) -> ToolPose:
            position, velocity = path.pose_at(min(t, stop))
            return ToolPose(position, velocity if t < stop else 0.0 * velocity)

        def sample(st: SimState, eng: Engine) -> bool:
            assert tracks is not None
            tracks.record(st, eng)
            return False

        if not tracks.times:
            tracks.record(state, engine)
        remaining = max(0, math.ceil(args.end_s / dt) - state.step)
        remaining -= remaining % per_out
        state = steps_with_checkpoints(
            engine, state, remaining, work, 'drive', args.checkpoint_min, 'drive', motion,
            per_block=per_out, extra=tracks.arrays, on_block=sample)
        work.save({**engine.checkpoint(state), **tracks.arrays()}, 'done', tool_stop_s=stop)
    return summary(scene, work, args)


def summary(scene: SceneSpec, work: Work, args: argparse.Namespace) -> dict[str, Any]:
    """The JSON figures: wall times, memory, and the marker statistics if the drive is done."""
    out: dict[str, Any] = {'scene': scene.name, 'sleep': args.sleep, 'stage': work.stage,
                           'particles': work.rec.get('particles'),
                           'wall_s': work.rec['wall_s'],
                           'wall_h_total': sum(work.rec['wall_s'].values()) / 3600,
                           'processes': work.rec['processes'],
                           'peak_rss_bytes_this_process': peak_rss_bytes(),
                           'paper_rocky_hours': PAPER_ROCKY_HOURS}
    if work.stage == 'done':
        with np.load(work.cp) as data:
            tr = Tracks.from_arrays(data)
        pos = np.asarray(tr.positions)
        disp = np.linalg.norm(pos[-1] - pos[0], axis=1)
        axis = tr.numbers <= scene.markers.columns
        times = np.asarray(tr.times)
        moving = (times > 0) & (times <= float(work.rec['tool_stop_s']))
        out.update({'axis_markers_mean_displacement_m': float(disp[axis].mean()),
                    'lateral_markers_mean_displacement_m': float(disp[~axis].mean()),
                    'mean_draft_n': float(-np.asarray(tr.force)[moving, 2].mean())})
    return out


def main() -> None:
    """Run from where the work folder stands and print the JSON line."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--scene', default='builtin:paper_1ms')
    parser.add_argument('--work', type=Path, required=True, help='checkpoints and progress')
    parser.add_argument('--sleep', action=argparse.BooleanOptionalAction, default=True)
    parser.add_argument('--settle-max-s', type=float, default=1.0,
                        help='longest settle [s of simulated time]')
    parser.add_argument('--end-s', type=float, default=3.0, help='simulated pass [s]')
    parser.add_argument('--checkpoint-min', type=float, default=30.0)
    args = parser.parse_args()
    print(json.dumps(run(args), default=float))


if __name__ == '__main__':
    main()
