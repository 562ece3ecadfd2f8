"""Speed and memory of the dempath DEM engine on a settled bed with a moving chisel.

Builds a bed of >= 45,000 spheres (4 mm, the paper's Table 6 sand: E 1.7 MPa, e 0.3, mu_s 0.71,
mu_d 0.59, mu_r 0.26; steel tool and walls from Table 2), settles it, inserts the shipped chisel
40 mm deep and drives it along +Z at 1 m/s. Prints particle-steps per second, the time per stage,
bytes per particle and per neighbour pair, and checks that the paper's 11,473,727-particle scene
fits in 24 GB by arithmetic and by building the engine arrays for that many particles.
Last line: one JSON object.

    .venv/bin/python bench/dem_engine_speed.py [--steps 600] [--skip-alloc] [--no-rolling]
"""

from __future__ import annotations

import argparse
import dataclasses
import gc
import json
import logging
import resource
import time
from pathlib import Path

import numba
import numpy as np

from dempath_sim.engine import Engine, ToolPose
from dempath_sim.engine.materials import Interaction, Material
from dempath_sim.engine.mesh import TriangleMesh
from dempath_sim.engine.params import SimParams
from dempath_sim.engine.sleep import SleepSettings
from dempath_sim.engine.state import SimState
from dempath_sim.engine.walls import box_walls

PAPER_PARTICLES = 11_473_727
RAM_BYTES = 24 * 2 ** 30
RADIUS = 2.0e-3  # m
SAND = Material('sand', 2650.0, 1.7e6, 0.25)
STEEL = Material('steel', 7800.0, 2.1e11, 0.3)
PARAMS = SimParams((SAND, STEEL), {
    (0, 0): Interaction(0.3, 0.71, 0.59, rolling_resistance=0.26),
    (0, 1): Interaction(0.3, 0.40, 0.30, rolling_resistance=0.26)},
    domain_min=(-1.0, -0.5, -1.0), domain_max=(1.0, 1.0, 1.0))
BIN_LO = (-0.08, 0.0, 0.0)  # m
BIN_HI = (0.08, 0.3, 0.25)  # m
CHISEL = Path(__file__).resolve().parents[1] / 'src/dempath_sim/dempath_sim/data/chisel.stl'


def without_rolling(params: SimParams) -> SimParams:
    """The same parameters with rolling resistance off (Hertz-Mindlin with history only)."""
    inter = {k: dataclasses.replace(v, rolling_resistance=0.0)
             for k, v in params.interactions.items()}
    return dataclasses.replace(params, interactions=inter)


def lattice_bed(layers: int) -> SimState:
    """Spheres on a jittered simple-cubic lattice in the bin (it collapses when settling)."""
    rng = np.random.default_rng(0)
    step = 2.05 * RADIUS
    xs = np.arange(BIN_LO[0] + step / 2, BIN_HI[0] - RADIUS, step)
    zs = np.arange(BIN_LO[2] + step / 2, BIN_HI[2] - RADIUS, step)
    ys = BIN_LO[1] + step / 2 + step * np.arange(layers)
    pos = np.stack(np.meshgrid(xs, ys, zs, indexing='ij'), axis=-1).reshape(-1, 3)
    pos += rng.uniform(-0.02, 0.02, size=pos.shape) * RADIUS
    return SimState.from_spheres(pos, RADIUS, 0, PARAMS)


def settle(state: SimState, steps: int) -> SimState:
    """Let the bed fall and settle in the bin without the tool."""
    engine = Engine(PARAMS, walls=box_walls(BIN_LO, BIN_HI, material=1))
    return engine.run(state, steps)


def settled_bed(layers: int, settle_steps: int) -> SimState:
    """The settled bed at rest: from the /tmp cache, or settled now and cached.

    Either way the bed is only its positions, at rest, with ids 0..n-1 (what the cache keeps):
    a bed handed over straight from the settle carried its velocities (after 4,000 steps the
    21-layer lattice is still moving), so a fresh machine timed a different run from the
    cached one, and that run stopped on an overlap.
    """
    cache = Path(f'/tmp/dempath_bench_bed_{layers}_{settle_steps}.npz')
    if not cache.exists():
        state = settle(lattice_bed(layers), settle_steps)
        np.savez(cache, positions=state.positions)
        logging.getLogger('bench').info('settled %d spheres (KE %.3e J), cached in %s',
                                        state.n, state.kinetic_energy(), cache)
    with np.load(cache) as data:
        return SimState.from_spheres(data['positions'], RADIUS, 0, PARAMS)


def insert_tool(state: SimState, depth: float, tip_z: float) -> tuple[SimState, np.ndarray]:
    """Remove the spheres in the chisel's boxes (share and shank) and return the tip position."""
    surface = float(np.percentile(state.positions[:, 1], 99.5)) + RADIUS
    tip = np.array([0.0, surface - depth, tip_z])
    lo_share = tip + np.array([-0.03, 0.0, -0.17])
    hi_share = tip + np.array([0.03, 0.08, 0.0])
    lo_shank = tip + np.array([-0.015, 0.0, -0.17])
    hi_shank = tip + np.array([0.015, 0.6, 0.0])
    inside = np.zeros(state.n, bool)
    for lo, hi in ((lo_share, hi_share), (lo_shank, hi_shank)):
        inside |= np.all((state.positions > lo - RADIUS) & (state.positions < hi + RADIUS), 1)
    return state.subset(~inside), tip


def timed_run(state: SimState, tip: np.ndarray, steps: int, skin: float,
              sleep: SleepSettings | None = None,
              local_rebuild: bool = False) -> dict[str, float]:
    """Run with the moving chisel; return the speed and the seconds spent in each stage.

    ``sleep``: let grains at rest sleep (changes results slightly; see engine/sleep.py).
    ``local_rebuild``: keep the list while grains moved together (engine/rebuild.py).
    """
    tool = TriangleMesh.from_stl(CHISEL, material=1)
    params = dataclasses.replace(PARAMS, skin=skin)
    engine = Engine(params, walls=box_walls(BIN_LO, BIN_HI, material=1), tool=tool,
                    sleep=sleep, local_rebuild=local_rebuild)
    speed = np.array([0.0, 0.0, 1.0])
    t_start = state.time

    def motion(t: float) -> ToolPose:
        return ToolPose(tip + speed * (t - t_start), speed)

    stages = {name: 0.0 for name in ('find_contacts', 'contact_forces', 'integrate_first_half',
                                     'integrate_second_half')}
    state = engine.run(state, 20, tool_motion=motion)  # compile + first build
    for name in stages:
        inner = getattr(engine, name)

        def timed(*args: object, _inner=inner, _name=name) -> object:
            t0 = time.perf_counter()
            out = _inner(*args)
            stages[_name] += time.perf_counter() - t0
            return out
        setattr(engine, name, timed)
    rebuilds0 = engine.n_rebuilds
    kept0 = engine.kept_lists
    evals0 = engine.pair_evaluations
    t0 = time.perf_counter()
    cpu0 = time.process_time()
    state = engine.run(state, steps, tool_motion=motion)
    wall = time.perf_counter() - t0
    cpu = time.process_time() - cpu0
    mem = engine.memory_bytes()
    return {'particles': state.n, 'steps': steps, 'seconds': wall,
            'particle_steps_per_s': state.n * steps / wall, 'cpu_seconds': cpu,
            'particle_steps_per_cpu_s': state.n * steps / cpu, 'dt': engine.dt,
            'rebuilds': engine.n_rebuilds - rebuilds0, 'kept_lists': engine.kept_lists - kept0,
            'pair_evaluations_per_step': (engine.pair_evaluations - evals0) / steps,
            'asleep_at_end': engine.n_asleep, 'draft_force_n': float(
                engine.tool_force[2]), 'contacts': engine.n_contacts,
            'pairs': mem['pairs'], 'particle_bytes': mem['particle_arrays'] / state.n,
            'pair_bytes': mem['pair_arrays'] / max(mem['pairs'], 1),
            **{f'stage_{k}_s': v for k, v in stages.items()}}


def allocate_paper_scene(pairs_per_particle: float, pair_bytes: float) -> dict[str, float]:
    """Build the engine arrays for 11.47 M spheres and top the pair arrays up to the bed's
    measured pair density; report the peak resident memory."""
    n_side = int(np.ceil(PAPER_PARTICLES ** (1 / 3)))
    idx = np.arange(PAPER_PARTICLES)
    pos = np.stack([idx % n_side, (idx // n_side) % n_side, idx // n_side ** 2], axis=1)
    state = SimState.from_spheres(pos * 2.2 * RADIUS, RADIUS, 0, PARAMS)
    del pos, idx
    gc.collect()
    engine = Engine(PARAMS)
    engine.bind(state)
    for arr in (*vars(engine).values(), *vars(state).values()):
        if isinstance(arr, np.ndarray) and arr.size:
            arr.reshape(-1)[::512] += 0  # write every page so it is resident, not just reserved
    have = engine.memory_bytes()
    extra_pairs = max(0, int(pairs_per_particle * state.n) - have['pairs'])
    top_up = np.ones(int(extra_pairs * pair_bytes) // 8)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    total = have['particle_arrays'] + have['pair_arrays'] + top_up.nbytes
    del top_up, engine, state
    gc.collect()
    return {'paper_particles': PAPER_PARTICLES, 'paper_engine_bytes': total,
            'paper_peak_rss_bytes': peak, 'paper_fits_24gb': bool(peak < RAM_BYTES)}


def main() -> None:
    """Run the benchmark and print the JSON line."""
    global PARAMS  # --no-rolling swaps the module's parameters
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--steps', type=int, default=600)
    parser.add_argument('--layers', type=int, default=21, help='>= 45,000 spheres after the slot')
    parser.add_argument('--no-rolling', action='store_true', help='rolling resistance off')
    parser.add_argument('--settle-steps', type=int, default=4000)
    parser.add_argument('--skip-alloc', action='store_true')
    parser.add_argument('--shuffle', action='store_true',
                        help='particles in random index order (as a fill leaves them), not the '
                             "lattice's spatial order")
    parser.add_argument('--skin', type=float, default=PARAMS.skin,
                        help='neighbour skin / smallest radius')
    parser.add_argument('--sleep', action='store_true',
                        help='grains at rest sleep (engine/sleep.py; changes results slightly)')
    parser.add_argument('--local-rebuild', action='store_true',
                        help='keep the neighbour list while grains moved together '
                             '(engine/rebuild.py; same contacts)')
    args = parser.parse_args()
    logging.basicConfig(level=logging.INFO, format='%(message)s')
    log = logging.getLogger('bench')
    t0 = time.perf_counter()
    state = settled_bed(args.layers, args.settle_steps)
    log.info('settled bed of %d spheres at rest (%.1f s)', state.n, time.perf_counter() - t0)
    if args.no_rolling:  # after the (cached) settle with rolling; timed_run reads PARAMS
        PARAMS = without_rolling(PARAMS)
    state, tip = insert_tool(state, depth=0.04, tip_z=0.08)
    if args.shuffle:
        state = state.subset(np.random.default_rng(1).permutation(state.n))
    result = timed_run(state, tip, args.steps, args.skin,
                       SleepSettings() if args.sleep else None, args.local_rebuild)
    per_particle = result['particle_bytes'] + result['pair_bytes'] * result['pairs'] / state.n
    result.update({'threads': numba.get_num_threads(), 'skin': args.skin,
                   'shuffled': args.shuffle, 'local_rebuild': args.local_rebuild,
                   'rolling': PARAMS.rolling_enabled,
                   'bytes_per_particle': per_particle,
                   'bytes_per_contact': result['pair_bytes'],
                   'paper_bytes_arithmetic': per_particle * PAPER_PARTICLES})
    for key, value in result.items():
        log.info('%-32s %s', key, f'{value:.4g}' if isinstance(value, float) else value)
    if not args.skip_alloc:
        result.update(allocate_paper_scene(result['pairs'] / state.n, result['pair_bytes']))
        log.info('paper scene: %.2f GB engine arrays, peak RSS %.2f GB',
                 result['paper_engine_bytes'] / 1e9, result['paper_peak_rss_bytes'] / 1e9)
    print(json.dumps({'particles': result['particles'], 'steps': result['steps'],
                      'dempath_particle_steps_per_s': result['particle_steps_per_s'],
                      **result}))


if __name__ == '__main__':
    main()
