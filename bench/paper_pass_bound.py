"""What bounds the paper's full-scale pass on this machine: a cost model of measured terms.

Driving ``paper_1ms`` at full size (11.3 M spheres) takes far longer than a session, so this
bench measures the pass's terms on pieces of the scene and adds them up for the full bed
(issue 30's goal: pour, settle and drive through 3 s in at most 6 h on 2 cores):

1. **settle** (``settle_<mm>``): a full-depth slice of the bed (both layers, a square plan of
   ``--slices`` mm; walls on all four sides) poured as ``bench/paper_full_pass.py`` pours it
   (the lattice pour, at rest) and settled with sleeping on until the fill's rule fires (fastest
   grain below ``fill.settle_speed_m_s``, not before 0.1 s) or ``--settle-max-s``. Settle time
   is set by the bed's depth and layering, not its plan size; two plan sizes show the walls'
   part. Per block: fastest, 99th percentile and median speed, kinetic energy, grains asleep,
   list builds and CPU time.
2. **costs** (``costs``): on the first slice's settled bed, CPU per step of the same bed three
   ways, alternated in rounds: sleeping off (every grain integrated, every pair evaluated),
   sleeping on as the settle left it, and the *floor* (every grain forced asleep: what a step
   costs when nothing moves: the O(n) passes, the scan of the list, the buffer reduction); each
   split by stage; and the CPU of a whole-bed list build.
3. **scale** (``scale``): the same three figures per grain on a bed of ``--scale-grains`` (the
   paper's pour closed up to touching neighbours, as ``bench/paper_scene_steps.py`` builds its
   full-scale bed): per-grain costs at a size far beyond the caches.
4. **drive** (``drive``): the settled slice tiled into a piece of ``--tiles`` slices, the chisel
   placed 184 mm deep and the piece re-settled against it for ``tool.settle_s`` (the pass's
   place stage), then driven at the profile's full speed for ``--drive-s`` with sleeping on,
   once with the whole-bed rebuild rule and once with the kept list: grains awake (and where,
   relative to the tip), pair evaluations, list builds per metre of travel, CPU by stage.

The last line's ``bound`` adds the terms for the full bed (each from measured terms; CPU
seconds over 2 cores, i.e. perfect scaling: a floor) and names the term that stops the pass.
Every stage runs with one numba thread; CPU is the process's user + system time. Stages are
cached in ``--cache`` (JSON and checkpoints); an interrupted run resumes. Last line: one JSON.

    NUMBA_NUM_THREADS=1 nice -n 10 .venv/bin/python bench/paper_pass_bound.py \\
        [--cache ~/.cache/dempath/paper_pass_bound] [--slices 63,126] [--tiles 3x5]
"""

from __future__ import annotations

import argparse
import json
import logging
import math
import os
import resource
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import replace
from pathlib import Path
from typing import Any

import numba
import numpy as np

from dempath_sim.engine import Engine, SimState, ToolPose, TriangleMesh
from dempath_sim.engine.sleep import SleepSettings
from dempath_sim.runs.bed import place_tool
from dempath_sim.runs.bed.measure import surface_height
from dempath_sim.runs.bed.pour import lattice_pour
from dempath_sim.runs.physics import TOOL, bin_walls, build_params
from dempath_sim.scene import SceneSpec, load_scene

log = logging.getLogger('bench')
N_FULL = 11_340_204  # spheres of paper_1ms's lattice pour at full size (figures.md)
STEP_S_FULL = 3.70  # seconds per step measured at full size, 2 threads, load ~2 (figures.md)
PASS_S = 3.0  # simulated time of the paper's pass [s]
GOAL_H = 6.0  # issue 30's goal [h]
CORES = 2
MIN_SETTLE_S = 0.1  # the fill's rule: never settled before this [s] (runs/bed/settle.py)
BLOCK_S = 0.005  # simulated time between trace points [s]
CLOSED_GAP = 0.998  # lattice spacing / diameter of the scale bed (paper_scene_steps.py)
STAGES = ('first_half', 'find_contacts', 'contact_forces', 'second_half')


def cpu_s() -> float:
    """User + system CPU seconds of this process."""
    return time.process_time()


def load() -> float:
    """The 1-minute load average."""
    return os.getloadavg()[0]


def peak_rss_gb() -> float:
    """Peak resident memory of this process [GB]."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20


class StageClock:
    """CPU seconds spent in each named stage of an engine's step (wraps its methods)."""

    def __init__(self, engine: Engine) -> None:
        """Wrap the four stages of ``engine``."""
        self.spent = dict.fromkeys(STAGES, 0.0)
        for name in STAGES:
            stage = 'integrate_' + name if name.endswith('half') else name
            inner = getattr(engine, stage)
            setattr(engine, stage, self._timed(inner, name))

    def _timed(self, inner: Callable[..., Any], name: str) -> Callable[..., Any]:
        def timed(*args: Any) -> Any:
            t0 = cpu_s()
            out = inner(*args)
            self.spent[name] += cpu_s() - t0
            return out
        return timed

    def take(self) -> dict[str, float]:
        """The seconds since the last take, by stage."""
        out, self.spent = self.spent, dict.fromkeys(STAGES, 0.0)
        return out


def piece_scene(scene: SceneSpec, width_m: float, length_m: float) -> SceneSpec:
    """``scene`` with its bin cut to ``width_m`` x ``length_m`` (full depth and layers)."""
    return replace(scene, bin=replace(scene.bin, width_x_m=width_m, length_z_m=length_m))


def with_layers(state: SimState) -> SimState:
    """``state`` with ``extra['layer']`` (1 for the finest grains, the top layer)."""
    state.extra['layer'] = (state.radii <= 1.01 * state.radii.min()).astype(np.int32)
    return state


def engine_for(scene: SceneSpec, tool: bool, sleep: bool, local: bool = False) -> Engine:
    """The engine of the scene's physics and walls, with or without the chisel."""
    params = build_params(scene, scene.physics_model())
    mesh = TriangleMesh.from_stl(scene.tool.mesh, material=TOOL, scale=scene.tool.scale)
    return Engine(params, bin_walls(scene), mesh if tool else None,
                  sleep=SleepSettings() if sleep else None, local_rebuild=local)


def speeds(state: SimState) -> np.ndarray:
    """(n,) speeds [m/s]."""
    return np.sqrt((state.velocities ** 2).sum(axis=1))


class Cache:
    """The bench's folder: one JSON per finished stage, checkpoints of unfinished ones."""

    def __init__(self, folder: Path) -> None:
        """Create ``folder`` if needed."""
        folder.mkdir(parents=True, exist_ok=True)
        self.folder = folder

    def done(self, stage: str) -> dict[str, Any] | None:
        """The figures of a finished stage, or None."""
        path = self.folder / f'{stage}.json'
        return json.loads(path.read_text()) if path.is_file() else None

    def finish(self, stage: str, figures: dict[str, Any]) -> dict[str, Any]:
        """Keep a stage's figures (atomic write) and return them."""
        tmp = self.folder / f'{stage}.tmp.json'
        tmp.write_text(json.dumps(figures, default=float, indent=1))
        tmp.replace(self.folder / f'{stage}.json')
        return figures

    def save(self, name: str, arrays: dict[str, Any]) -> None:
        """Write checkpoint ``name`` atomically."""
        tmp = self.folder / f'{name}.tmp.npz'
        np.savez(tmp, **arrays)
        tmp.replace(self.folder / f'{name}.npz')

    @contextmanager
    def load(self, name: str) -> Iterator[Any]:
        """Checkpoint ``name`` (an open npz)."""
        with np.load(self.folder / f'{name}.npz') as data:
            yield data

    def has(self, name: str) -> bool:
        """Whether checkpoint ``name`` exists."""
        return (self.folder / f'{name}.npz').is_file()


# ----------------------------------------------------------------------------- settle
def trace_point(state: SimState, engine: Engine, scene: SceneSpec, cpu: float,
                steps: int) -> dict[str, float]:
    """One point of the settle's trace."""
    v = speeds(state)
    fine = state.radii <= 1.01 * state.radii.min()
    base_top = float(np.quantile(state.positions[~fine, 1], 0.9)) if (~fine).any() else -np.inf
    return {'fines_below_base_top': float(np.mean(state.positions[fine, 1] < base_top)),
            't_s': state.time, 'vmax_m_s': float(v.max()), 'v99_m_s': float(np.quantile(v, 0.99)),
            'v50_m_s': float(np.median(v)), 'ke_j': float(0.5 * (state.masses * v * v).sum()),
            'asleep': engine.n_asleep, 'builds': engine.n_rebuilds,
            'surface_m': surface_height(scene, with_layers(state)),
            'cpu_s': cpu, 'steps': steps, 'load': load()}


def settle_slice(scene: SceneSpec, side_mm: int, cache: Cache, settle_max_s: float,
                 checkpoint_min: float) -> dict[str, Any]:
    """Pour and settle a full-depth slice of ``side_mm`` x ``side_mm`` (module doc, stage 1)."""
    stage = f'settle_{side_mm}'
    if (found := cache.done(stage)) is not None:
        return found
    sub = piece_scene(scene, side_mm / 1000, side_mm / 1000)
    engine = engine_for(sub, tool=False, sleep=True)
    if cache.has(stage):
        with cache.load(stage) as data:
            state = engine.resume(data)
            trace = json.loads(str(data['trace']))
            pour_cpu = float(data['pour_cpu'])
        log.info('%s: resumed at t = %.4f s', stage, state.time)
    else:
        c0 = cpu_s()
        model = sub.physics_model()
        state = lattice_pour(sub, model, build_params(sub, model))
        state.velocities[:] = 0.0
        engine.bind(state)
        pour_cpu = cpu_s() - c0
        trace = [trace_point(state, engine, sub, 0.0, 0)]
        log.info('%s: %d grains poured (lattice) in %.1f s CPU', stage, state.n, pour_cpu)
    dt = float(engine.dt or 0.0)
    block = max(1, round(BLOCK_S / dt))
    limit = sub.fill.settle_speed_m_s
    t_save = time.monotonic()
    while state.time < settle_max_s - 0.5 * dt:
        c0 = cpu_s()
        state = engine.run(state, block)
        trace.append(trace_point(state, engine, sub, cpu_s() - c0, block))
        p = trace[-1]
        if len(trace) % 10 == 0:
            log.info('%s: t = %.3f s, vmax %.4f m/s, v99 %.4f, median %.5f, %d of %d asleep, '
                     '%.1f ms CPU/step, fines below the base top %.3f, load %.1f', stage,
                     p['t_s'], p['vmax_m_s'], p['v99_m_s'], p['v50_m_s'], p['asleep'], state.n,
                     1e3 * p['cpu_s'] / block, p['fines_below_base_top'], p['load'])
        if p['t_s'] >= MIN_SETTLE_S and p['vmax_m_s'] < limit:
            break
        if time.monotonic() - t_save > 60 * checkpoint_min:
            cache.save(stage, {**engine.checkpoint(state), 'trace': np.array(json.dumps(trace)),
                               'pour_cpu': pour_cpu})
            t_save = time.monotonic()
    cache.save(stage, {**engine.checkpoint(state), 'trace': np.array(json.dumps(trace)),
                       'pour_cpu': pour_cpu})
    return cache.finish(stage, settle_figures(sub, side_mm, state, dt, trace, pour_cpu, limit))


def settle_figures(sub: SceneSpec, side_mm: int, state: SimState, dt: float,
                   trace: list[dict[str, float]], pour_cpu: float,
                   limit: float) -> dict[str, Any]:
    """The settle's figures: when each rule fires, the speed decay, the grains still fast at
    the end, and the CPU per grain spent up to each trace point (``cum_cpu_per_grain_s``; the
    first block, which compiles the kernels, counted as the second)."""
    t = np.array([p['t_s'] for p in trace])
    vmax = np.array([p['vmax_m_s'] for p in trace])
    fired = [p['t_s'] for p in trace[1:] if p['t_s'] >= MIN_SETTLE_S and p['vmax_m_s'] < limit]
    bench_rule = [p['t_s'] for p in trace[1:] if p['vmax_m_s'] < limit]
    bulk_rule = [p['t_s'] for p in trace[1:] if p['t_s'] >= MIN_SETTLE_S and p['v99_m_s'] < limit]
    cpu = [0.0] + [p['cpu_s'] for p in trace[1:]]
    if len(cpu) > 2:
        cpu[1] = cpu[2]
    cum = np.cumsum(cpu) / state.n
    for p, c in zip(trace, cum, strict=True):
        p['cum_cpu_per_grain_s'] = float(c)
    steps = sum(p['steps'] for p in trace[1:])
    late = t >= max(t[-1] - 0.2, MIN_SETTLE_S)
    slope = (float(np.polyfit(t[late], np.log(vmax[late]), 1)[0])
             if late.sum() >= 3 and (vmax[late] > 0).all() else math.nan)
    v = speeds(state)
    fast = v >= limit
    fine = state.radii <= 1.01 * state.radii.min()
    base_top = float(state.positions[~fine, 1].max()) if (~fine).any() else -np.inf
    return {'side_m': side_mm / 1000, 'grains': state.n, 'dt_s': dt,
            'walls_per_m': 4 / (side_mm / 1000),
            'settle_rule_s': fired[0] if fired else None,
            'paper_full_pass_rule_s': bench_rule[0] if bench_rule else None,
            'v99_rule_s': bulk_rule[0] if bulk_rule else None,
            'settle_max_reached': not fired, 't_end_s': float(t[-1]),
            'vmax_end_m_s': float(vmax[-1]), 'vmax_log_slope_last_0_2_s': slope,
            'fast_at_end': int(fast.sum()), 'fast_fines_at_end': int((fast & fine).sum()),
            'fast_fines_inside_base_at_end': int(
                (fast & fine & (state.positions[:, 1] < base_top)).sum()),
            'asleep_end': trace[-1]['asleep'], 'builds': trace[-1]['builds'],
            'steps_between_builds': steps / max(trace[-1]['builds'] - trace[0]['builds'], 1),
            'surface_start_m': trace[0]['surface_m'], 'surface_end_m': trace[-1]['surface_m'],
            'fines_below_base_top_end': trace[-1]['fines_below_base_top'],
            'cpu_per_particle_step_s': float(cum[-1]) / max(steps, 1),
            'pour_cpu_s': pour_cpu, 'load_range': [min(p['load'] for p in trace[1:]),
                                                  max(p['load'] for p in trace[1:])],
            'trace': trace[::4] + ([trace[-1]] if (len(trace) - 1) % 4 else [])}


def cpu_per_grain_until(settle: dict[str, Any], t_s: float) -> float:
    """CPU seconds per grain the slice's settle spent up to ``t_s`` (linear between points)."""
    tr = settle['trace']
    return float(np.interp(t_s, [p['t_s'] for p in tr], [p['cum_cpu_per_grain_s'] for p in tr]))


# ----------------------------------------------------------------------------- costs
def force_asleep(engine: Engine) -> None:
    """Put every grain of the engine's bed to sleep, off the rim (the floor of a step)."""
    engine._asleep_u8[:] = 1
    engine._rim_u8[:] = 0
    engine.n_asleep = engine._asleep_u8.size


def wake_all(engine: Engine) -> None:
    """Wake every grain (a resumed checkpoint's sleep state, for the engine without sleep)."""
    engine._asleep_u8[:] = 0
    engine._rim_u8[:] = 0
    engine.n_asleep = 0


def timed_block(engine: Engine, state: SimState, clock: StageClock,
                steps: int) -> tuple[SimState, dict[str, Any]]:
    """``steps`` steps of ``engine``: CPU per step, by stage, evaluations, builds."""
    evals0, builds0 = engine.pair_evaluations, engine.n_rebuilds
    clock.take()
    c0 = cpu_s()
    state = engine.run(state, steps)
    total = cpu_s() - c0
    by_stage = clock.take()
    return state, {'cpu_per_step_s': total / steps,
                   **{f'{k}_per_step_s': v / steps for k, v in by_stage.items()},
                   'other_per_step_s': (total - sum(by_stage.values())) / steps,
                   'evaluations_per_step': (engine.pair_evaluations - evals0) / steps,
                   'builds': engine.n_rebuilds - builds0, 'asleep': engine.n_asleep}


def build_cost(engine: Engine, state: SimState, count: int) -> float:
    """Median CPU seconds of one whole-bed list build (reorder, cells, springs carried)."""
    out = []
    for _ in range(count):
        c0 = cpu_s()
        engine.find_contacts(state, np.arange(state.n))
        out.append(cpu_s() - c0)
    return float(np.median(out))


def median_block(blocks: list[dict[str, Any]]) -> dict[str, Any]:
    """Median of each figure over the rounds."""
    return {k: float(np.median([b[k] for b in blocks])) for k in blocks[0]}


def step_costs(scene: SceneSpec, side_mm: int, cache: Cache, steps: int,
               rounds: int) -> dict[str, Any]:
    """Sleeping off, as left and forced asleep on the settled slice, alternated (stage 2)."""
    if (found := cache.done('costs')) is not None:
        return found
    sub = piece_scene(scene, side_mm / 1000, side_mm / 1000)
    runs: dict[str, tuple[Engine, SimState, StageClock]] = {}
    for name, sleep in (('off', False), ('as_left', True), ('floor', True)):
        engine = engine_for(sub, tool=False, sleep=sleep)
        with cache.load(f'settle_{side_mm}') as data:
            state = engine.resume(data)
        if not sleep:
            wake_all(engine)
        runs[name] = (engine, state, StageClock(engine))
    blocks: dict[str, list[dict[str, Any]]] = {k: [] for k in runs}
    loads = [load()]
    for r in range(rounds + 1):  # round 0 warms the kernels up; not counted
        for name, (engine, state, clock) in runs.items():
            if name == 'floor':
                force_asleep(engine)
            state, fig = timed_block(engine, state, clock, steps)
            runs[name] = (engine, state, clock)
            if r:
                blocks[name].append(fig)
        loads.append(load())
        log.info('costs: round %d of %d, load %.1f', r, rounds, loads[-1])
    engine, state, _ = runs['off']
    n, pairs = state.n, engine.n_pairs
    figures = {name: median_block(b) for name, b in blocks.items()}
    build = build_cost(engine, state, 5)
    return cache.finish('costs', {
        'grains': n, 'listed_pairs': pairs, 'contacts': engine.n_contacts,
        'steps_per_block': steps, 'rounds': rounds, **figures,
        'build_cpu_s': build, 'build_per_grain_s': build / n,
        'off_per_grain_s': figures['off']['cpu_per_step_s'] / n,
        'floor_per_grain_s': figures['floor']['cpu_per_step_s'] / n,
        'load_range': [min(loads), max(loads)]})


def kept_costs(scene: SceneSpec, side_mm: int, cache: Cache, steps: int,
               rounds: int) -> dict[str, Any]:
    """Sleeping on as the settle left it, with the whole-bed rebuild rule and with the kept list,
    alternated on the settled slice: how often its falling fines force a build either way."""
    if (found := cache.done('kept')) is not None:
        return found
    sub = piece_scene(scene, side_mm / 1000, side_mm / 1000)
    runs: dict[str, tuple[Engine, SimState, StageClock]] = {}
    for name, local in (('whole_bed', False), ('kept_list', True)):
        engine = engine_for(sub, tool=False, sleep=True, local=local)
        with cache.load(f'settle_{side_mm}') as data:
            state = engine.resume(data)
        runs[name] = (engine, state, StageClock(engine))
    blocks: dict[str, list[dict[str, Any]]] = {k: [] for k in runs}
    loads = [load()]
    for r in range(rounds + 1):  # round 0 warms the kernels up; not counted
        for name, (engine, state, clock) in runs.items():
            state, fig = timed_block(engine, state, clock, steps)
            runs[name] = (engine, state, clock)
            if r:
                blocks[name].append(fig)
        loads.append(load())
    return cache.finish('kept', {
        'grains': runs['whole_bed'][1].n, 'steps_per_block': steps, 'rounds': rounds,
        **{name: median_block(b) for name, b in blocks.items()},
        'load_range': [min(loads), max(loads)]})


def scale_costs(scene: SceneSpec, cache: Cache, grains: int, steps: int) -> dict[str, Any]:
    """Per-grain step, floor and build costs on a closed-lattice bed of ``grains`` (stage 3)."""
    if (found := cache.done('scale')) is not None:
        return found
    per_m2 = N_FULL / (scene.bin.width_x_m * scene.bin.length_z_m)
    side = math.sqrt(grains / per_m2)
    sub = piece_scene(scene, side, side)
    model = sub.physics_model()
    loads = [load()]
    c0 = cpu_s()
    state = lattice_pour(sub, model, build_params(sub, model), gap=CLOSED_GAP)
    state.velocities[:] = 0.0
    pour = cpu_s() - c0
    engine = engine_for(sub, tool=False, sleep=True)
    c0 = cpu_s()
    engine.bind(state)
    bind = cpu_s() - c0
    log.info('scale: %d grains, pour %.1f s, bind %.1f s CPU, load %.1f', state.n, pour, bind,
             load())
    clock = StageClock(engine)
    blocks: dict[str, list[dict[str, Any]]] = {'awake': [], 'floor': []}
    builds = []
    for _ in range(2):
        for name in blocks:
            (wake_all if name == 'awake' else force_asleep)(engine)
            state, fig = timed_block(engine, state, clock, steps)
            blocks[name].append(fig)
        builds.append(build_cost(engine, state, 1))
        loads.append(load())
    n = state.n
    figures = {name: median_block(b) for name, b in blocks.items()}
    return cache.finish('scale', {
        'grains': n, 'listed_pairs': engine.n_pairs, 'steps_per_block': steps, **figures,
        'pour_cpu_s': pour, 'bind_cpu_s': bind, 'pour_per_grain_s': pour / n,
        'bind_per_grain_s': bind / n, 'build_cpu_s': float(np.median(builds)),
        'build_per_grain_s': float(np.median(builds)) / n,
        'awake_per_grain_s': figures['awake']['cpu_per_step_s'] / n,
        'floor_per_grain_s': figures['floor']['cpu_per_step_s'] / n,
        'peak_rss_gb': peak_rss_gb(), 'load_range': [min(loads), max(loads)]})


# ----------------------------------------------------------------------------- drive
def tiled_bed(scene: SceneSpec, side_mm: int, cache: Cache,
              tiles: tuple[int, int]) -> tuple[SceneSpec, SimState]:
    """The settled slice repeated ``tiles`` = (across, along) times: a wider, longer piece of
    the same depth (the slices' walls become seams of grains that touch across them)."""
    side = side_mm / 1000
    nx, nz = tiles
    with cache.load(f'settle_{side_mm}') as data:
        parts = {k: np.array(data[f'state.{k}']) for k in (
            'positions', 'velocities', 'angular_velocities', 'radii', 'masses', 'inertias',
            'material')}
    copies: dict[str, list[np.ndarray]] = {k: [] for k in parts}
    for i in range(nx):
        for k in range(nz):
            for key, value in parts.items():
                copies[key].append(value.copy())
            copies['positions'][-1] += [(i - (nx - 1) / 2) * side, 0.0, k * side]
    joined = {k: np.concatenate(v) for k, v in copies.items()}
    state = SimState(**joined, ids=np.arange(len(joined['radii'])))  # type: ignore[arg-type]
    return piece_scene(scene, nx * side, nz * side), with_layers(state)


def place_piece(scene: SceneSpec, side_mm: int, cache: Cache,
                tiles: tuple[int, int]) -> dict[str, Any]:
    """Tile, place the chisel (carve) and re-settle against it for ``tool.settle_s``."""
    if (found := cache.done('place')) is not None:
        return found
    piece, state = tiled_bed(scene, side_mm, cache, tiles)
    mesh = TriangleMesh.from_stl(scene.tool.mesh, material=TOOL, scale=scene.tool.scale)
    surface = surface_height(piece, state)
    tail = -float(mesh.triangles[..., 2].min())
    start = np.array([0.0, surface - scene.tool.depth_m, tail + 0.02])
    state, removed = place_tool(state, mesh, tuple(start), scene.tool.placement)
    engine = engine_for(piece, tool=True, sleep=True)
    engine.tool_pose = ToolPose(start, np.zeros(3))
    engine.bind(state)
    dt = float(engine.dt or 0.0)
    block = max(1, round(BLOCK_S / dt))
    trace = []
    c_all = cpu_s()
    while state.time < scene.tool.settle_s - 0.5 * dt:
        c0 = cpu_s()
        state = engine.run(state, block)
        trace.append(trace_point(state, engine, piece, cpu_s() - c0, block))
        log.info('place: t = %.3f s, vmax %.4f m/s, median %.5f, %d of %d asleep, load %.1f',
                 state.time, trace[-1]['vmax_m_s'], trace[-1]['v50_m_s'], engine.n_asleep,
                 state.n, trace[-1]['load'])
    cache.save('drive_start', engine.checkpoint(state))
    return cache.finish('place', {
        'width_m': piece.bin.width_x_m, 'length_m': piece.bin.length_z_m, 'tiles': tiles,
        'grains': state.n, 'removed_by_tool': removed, 'tool_start_m': start.tolist(),
        'surface_m': surface, 'settle_s': scene.tool.settle_s, 'cpu_s': cpu_s() - c_all,
        'asleep_end': engine.n_asleep, 'trace': trace})


def awake_extent(state: SimState, engine: Engine, tip: np.ndarray) -> dict[str, float]:
    """Where the awake grains lie relative to the tool's tip [m] (1st and 99th percentiles)."""
    awake = ~engine.asleep
    if not awake.any():
        return {}
    rel = state.positions[awake] - tip
    lo, hi = np.quantile(rel, [0.01, 0.99], axis=0)
    return {'awake_x_p99_m': float(np.quantile(np.abs(rel[:, 0]), 0.99)),
            'awake_y_p01_m': float(lo[1]), 'awake_z_p01_m': float(lo[2]),
            'awake_z_p99_m': float(hi[2])}


def drive_variant(scene: SceneSpec, place: dict[str, Any], cache: Cache, name: str,
                  local: bool, sleep: bool, drive_s: float) -> dict[str, Any]:
    """The chisel at the profile's full speed for ``drive_s`` from the placed piece."""
    stage = f'drive_{name}'
    if (found := cache.done(stage)) is not None:
        return found
    piece = piece_scene(scene, place['width_m'], place['length_m'])
    engine = engine_for(piece, tool=True, sleep=sleep, local=local)
    with cache.load('drive_start') as data:
        state = engine.resume(data)
    clock = StageClock(engine)
    start = np.asarray(place['tool_start_m'])
    v = np.array([0.0, 0.0, scene.tool.profile.speed_m_s])
    t0 = state.time

    def motion(t: float) -> ToolPose:
        return ToolPose(start + v * (t - t0), v)

    dt = float(engine.dt or 0.0)
    block = max(1, round(BLOCK_S / dt))
    blocks = []
    while state.time - t0 < drive_s - 0.5 * dt:
        evals0, builds0, kept0 = engine.pair_evaluations, engine.n_rebuilds, engine.kept_lists
        clock.take()
        c0 = cpu_s()
        state = engine.run(state, block, motion)
        cpu = cpu_s() - c0
        tip = start + v * (state.time - t0)
        blocks.append({'t_s': state.time - t0, 'cpu_per_step_s': cpu / block,
                       **{f'{k}_per_step_s': s / block for k, s in clock.take().items()},
                       'awake': state.n - engine.n_asleep,
                       'evaluations_per_step': (engine.pair_evaluations - evals0) / block,
                       'builds': engine.n_rebuilds - builds0,
                       'kept': engine.kept_lists - kept0, 'draft_n': float(engine.tool_force[2]),
                       'load': load(), **awake_extent(state, engine, tip)})
        b = blocks[-1]
        log.info('%s: t = %.3f s, %d of %d awake, %.0f evaluations/step, %d builds, '
                 '%.1f ms CPU/step, load %.1f', stage, b['t_s'], b['awake'], state.n,
                 b['evaluations_per_step'], b['builds'], 1e3 * b['cpu_per_step_s'], b['load'])
    counted = blocks[1:]  # the first block may compile kernels
    steps = block * len(counted)
    travel = float(v[2]) * dt * steps
    mean = {k: float(np.mean([b[k] for b in counted])) for k in (
        'cpu_per_step_s', 'awake', 'evaluations_per_step',
        *(f'{s}_per_step_s' for s in STAGES))}
    return cache.finish(stage, {
        'local_rebuild': local, 'sleep': sleep, 'grains': state.n, 'listed_pairs': engine.n_pairs,
        'steps': steps, 'travel_m': travel, **mean,
        'builds_per_m': sum(b['builds'] for b in counted) / travel,
        'kept_steps': sum(b['kept'] for b in counted), 'awake_last': counted[-1]['awake'],
        'load_range': [min(b['load'] for b in counted), max(b['load'] for b in counted)],
        'blocks': blocks})


def tool_reach(scene: SceneSpec, place: dict[str, Any], cache: Cache, drive_s: float,
               moved_m: float) -> dict[str, Any]:
    """Which grains the tool moves: the placed piece stepped twice for ``drive_s`` without
    sleeping, the chisel driven and standing; a grain whose end positions differ by more than
    ``moved_m`` is the tool's. Their count per metre of travel and where they lie."""
    if (found := cache.done('reach')) is not None:
        return found
    piece = piece_scene(scene, place['width_m'], place['length_m'])
    start = np.asarray(place['tool_start_m'])
    ends = []
    for speed in (scene.tool.profile.speed_m_s, 0.0):
        engine = engine_for(piece, tool=True, sleep=False)
        with cache.load('drive_start') as data:
            state = engine.resume(data)
        v = np.array([0.0, 0.0, speed])
        t0 = state.time

        def motion(t: float, v: np.ndarray = v, t0: float = t0) -> ToolPose:
            return ToolPose(start + v * (t - t0), v)

        steps = round(drive_s / float(engine.dt or 1.0))
        state = engine.run(state, steps, motion)
        order = np.argsort(state.ids)
        ends.append((state.ids[order], state.positions[order]))
        log.info('reach: tool at %.1f m/s done, load %.1f', speed, load())
    ids = np.intersect1d(ends[0][0], ends[1][0])
    a = ends[0][1][np.searchsorted(ends[0][0], ids)]
    b = ends[1][1][np.searchsorted(ends[1][0], ids)]
    moved = np.linalg.norm(a - b, axis=1) > moved_m
    travel = scene.tool.profile.speed_m_s * drive_s
    rel = a[moved] - start
    return cache.finish('reach', {
        'grains': len(ids), 'moved_m': moved_m, 'travel_m': travel,
        'moved_by_tool': int(moved.sum()), 'moved_per_m_of_travel': float(moved.sum() / travel),
        'x_abs_p99_m': float(np.quantile(np.abs(rel[:, 0]), 0.99)) if moved.any() else 0.0,
        'half_width_m': place['width_m'] / 2,
        'y_below_tip_p01_m': float(np.quantile(rel[:, 1], 0.01)) if moved.any() else 0.0,
        'z_p01_p99_m': np.quantile(rel[:, 2], [0.01, 0.99]).tolist() if moved.any() else [],
        'load': load()})


# ----------------------------------------------------------------------------- bound
def drive_times(scene: SceneSpec) -> tuple[float, float]:
    """(seconds the tool moves, seconds of the pass) of the scene's profile over its travel."""
    from dempath_sim.scene.profiles import ToolPath
    path = ToolPath(scene.tool.profile, (0.0, 0.0, 0.0), scene.tool.profile_offset_m)
    return float(path.time_to_travel(scene.tool.travel_m)), PASS_S


TOOL_BUILDS_PER_M = (1657.0, 1072.0)  # list builds per metre of tool travel, whole-bed rule and
# kept list: bench/dem_vs_liggghts.py idle (figures.md, 11-28 17:20 UTC): 85 and 55 builds in
# 600 steps of 85.5 us, the chisel at 1 m/s through 4 mm grains with nothing else moving


def full_bound(scene: SceneSpec, settles: list[dict[str, Any]], costs: dict[str, Any],
               scale: dict[str, Any], drives: dict[str, dict[str, Any]],
               settle_max_s: float) -> dict[str, Any]:
    """The full pass's hours from the measured terms (module doc); CPU over 2 cores.

    Settle: the slices' CPU per grain up to the time the rule fires, or up to ``settle_max_s``
    when it never fires (what ``paper_full_pass.py`` then does), and as a floor up to the time
    the bulk (99th percentile) is below the rule. Drive: every step as the settled bed steps
    with sleeping on as the settle left it (measured), and sleeping's floor: every grain asleep
    (the O(n) passes and the list scan) plus whole-bed builds at the tool's own rate, no work
    for the awake grains near the tool (not measured: a floor)."""
    dt = settles[0]['dt_s']
    per_h = N_FULL / (3600 * CORES)  # CPU seconds per grain -> hours of the full bed
    fired = [s['settle_rule_s'] for s in settles]
    settle_s = max(fired) if None not in fired else settle_max_s
    bulk_s = max((s['v99_rule_s'] or s['t_end_s']) for s in settles)
    moving_s, pass_s = drive_times(scene)
    drive_steps = pass_s / dt
    as_left = costs['as_left']['cpu_per_step_s'] / costs['grains']
    floor = max(costs['floor_per_grain_s'], scale['floor_per_grain_s'])
    build = min(costs['build_per_grain_s'], scale['build_per_grain_s'])
    place_steps = scene.tool.settle_s / dt
    out: dict[str, Any] = {
        'grains': N_FULL, 'dt_s': dt, 'cores': CORES,
        'settle_rule_fired': None not in fired, 'settle_s': settle_s, 'bulk_settled_s': bulk_s,
        'settle_steps': settle_s / dt, 'drive_steps': drive_steps, 'tool_moves_s': moving_s,
        'pour_h': N_FULL * (scale['pour_per_grain_s'] + scale['bind_per_grain_s'] / CORES)
        / 3600,
        'settle_h': max(cpu_per_grain_until(s, settle_s) for s in settles) * per_h,
        'settle_h_floor_bulk': max(cpu_per_grain_until(s, bulk_s) for s in settles) * per_h,
        'place_h': place_steps * as_left * per_h,
        'drive_h_as_settled': drive_steps * as_left * per_h,
        'drive_h_no_sleep': drive_steps * costs['off_per_grain_s'] * per_h,
        'full_step_s_as_settled': as_left * N_FULL / CORES,
        'full_step_s_floor': floor * N_FULL / CORES,
        'full_build_s': build * N_FULL / CORES,
        'full_step_s_awake_no_builds': scale['awake_per_grain_s'] * N_FULL / CORES}
    for name, rate in zip(('whole_bed', 'kept_list'), TOOL_BUILDS_PER_M, strict=True):
        builds = rate * scene.tool.travel_m
        floor_h = drive_steps * floor * per_h
        builds_h = builds * build * per_h
        out[f'drive_floor_{name}'] = {'builds': builds, 'floor_h': floor_h,
                                      'builds_h': builds_h, 'h': floor_h + builds_h}
    for name, d in drives.items():
        out[f'piece_builds_per_m_{name}'] = d['builds_per_m']
    fixed = out['pour_h'] + out['place_h']
    out['total_h'] = fixed + out['settle_h'] + out['drive_h_as_settled']
    out['total_h_floor'] = (fixed + out['settle_h_floor_bulk']
                            + out['drive_floor_kept_list']['h'])
    out['over_goal'] = out['total_h'] / GOAL_H
    out['floor_over_goal'] = out['total_h_floor'] / GOAL_H
    return out


def main() -> None:
    """Run the stages not yet cached, then print the bound as one JSON line."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--scene', default='builtin:paper_1ms')
    parser.add_argument('--cache', type=Path,
                        default=Path.home() / '.cache/dempath/paper_pass_bound')
    parser.add_argument('--slices', default='63,126',
                        help='plan sides of the settle slices [mm] (whole lattice cells)')
    parser.add_argument('--settle-max-s', type=float, default=1.0)
    parser.add_argument('--checkpoint-min', type=float, default=5.0)
    parser.add_argument('--cost-steps', type=int, default=100)
    parser.add_argument('--cost-rounds', type=int, default=3)
    parser.add_argument('--scale-grains', type=int, default=1_200_000)
    parser.add_argument('--tiles', default='3x5', help='across x along: the drive piece')
    parser.add_argument('--drive-s', type=float, default=0.05)
    parser.add_argument('--stages', default='settle,costs,kept,scale,drive,reach',
                        help='which stages may run (the others are read from the cache)')
    args = parser.parse_args()
    logging.basicConfig(level=logging.INFO, format='%(asctime)s %(message)s')
    numba.set_num_threads(1)
    scene = load_scene(args.scene)
    cache = Cache(args.cache)
    run = set(args.stages.split(','))
    sides = [int(s) for s in args.slices.split(',')]
    result: dict[str, Any] = {'scene': scene.name, 'threads': 1, 'load_start': load()}

    def settled(side: int) -> dict[str, Any] | None:
        return (settle_slice(scene, side, cache, args.settle_max_s, args.checkpoint_min)
                if 'settle' in run else cache.done(f'settle_{side}'))

    settles = [settled(sides[0])]  # the first slice feeds the costs and the drive piece
    costs = (step_costs(scene, sides[0], cache, args.cost_steps, args.cost_rounds)
             if 'costs' in run else cache.done('costs'))
    kept = (kept_costs(scene, sides[0], cache, args.cost_steps, args.cost_rounds)
            if 'kept' in run else cache.done('kept'))
    scale = (scale_costs(scene, cache, args.scale_grains, 5) if 'scale' in run
             else cache.done('scale'))
    drives: dict[str, dict[str, Any]] = {}
    if 'drive' in run or cache.done('place'):
        tiles = tuple(int(x) for x in args.tiles.split('x'))
        place = place_piece(scene, sides[0], cache, (tiles[0], tiles[1]))
        for name, local in (('whole_bed', False), ('kept_list', True)):
            if 'drive' in run or cache.done(f'drive_{name}'):
                drives[name] = drive_variant(scene, place, cache, name, local, True,
                                             args.drive_s)
        result['place'] = {k: v for k, v in place.items() if k != 'trace'}
        if 'reach' in run or cache.done('reach'):
            result['reach'] = tool_reach(scene, place, cache, args.drive_s, 5e-4)
    settles += [settled(side) for side in sides[1:]]  # the walls' part, last (the longest)
    result['settle'] = [{k: v for k, v in s.items() if k != 'trace'} for s in settles if s]
    result['costs'], result['kept'], result['scale'] = costs, kept, scale
    result['drive'] = {k: {x: y for x, y in v.items() if x != 'blocks'}
                       for k, v in drives.items()}
    if all(settles) and costs and scale:
        result['bound'] = full_bound(scene, [s for s in settles if s], costs, scale, drives,
                                     args.settle_max_s)
    result['peak_rss_gb'] = peak_rss_gb()
    result['load_end'] = load()
    print(json.dumps(result, default=float))


if __name__ == '__main__':
    main()
