"""dempath vs LIGGGHTS 3.8: particle-steps per second on one settled bed with the chisel passing.

Both engines run the same >= 45,000 spheres (the bed of ``bench/dem_engine_speed.py``: 4 mm sand,
Table 6 parameters, Hertz-Mindlin with history + EPSD2 rolling resistance, steel walls and the
shipped chisel 40 mm deep moving at 1 m/s), the same time step and the same number of steps, on
2 cores each: dempath with 2 numba threads, LIGGGHTS with ``mpirun -np 2`` (its loop time, i.e.
without start-up and file output). Then the cross-engine comparison on a small scene
(``--cross-scene``, ``--seeds`` packings per engine, LIGGGHTS settling dempath's loose pour of
each seed unless ``--fill`` says otherwise) gives ``cross_engine_ratio`` (difference of the
engines / packing-seed spread). Last line: one JSON object.

    .venv/bin/python bench/dem_vs_liggghts.py [--steps 600] [--np 2] [--skip-cross] [--sleep] \\
        [--local-rebuild]
    .venv/bin/python bench/dem_vs_liggghts.py --skip-speed --cross-scene builtin:reduced_1ms \\
        --seeds 3 --cache-dir /tmp/xe/packings --json-out docs/cross_engine_reduced.json
    .venv/bin/python bench/dem_vs_liggghts.py --skip-speed --cross-scene builtin:reduced_1ms \\
        --seeds 4 --fill shared_packing --variants all --results-dir /tmp/xe/results

``--variants`` runs the comparison for the baseline and for each candidate of the effects
library at the library's upper strength (``--strength lower``: its lower one;
``dempath_sim.validation.effect_variants``), every variant from the same packings;
``cross_engine_ratio`` is then the largest over the variants, ``cross_engine`` the first
variant's figures and ``cross_variants`` every variant's. With ``--results-dir`` an interrupted
run resumes (finished seeds are read back).
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import logging
import math
import sys
import tempfile
import time
from pathlib import Path
from types import ModuleType

import numba
import numpy as np

from dempath_sim.engine.sleep import SleepSettings
from dempath_sim.engine.state import SimState
from dempath_sim.engine.stl import read_stl
from dempath_sim.liggghts import commands as cmd
from dempath_sim.liggghts.install import ensure_liggghts
from dempath_sim.liggghts.runner import run_deck

HERE = Path(__file__).resolve().parent
log = logging.getLogger('bench')


def speed_bench() -> ModuleType:
    """H2's engine benchmark module (bed, tool insertion, timed dempath run), imported."""
    spec = importlib.util.spec_from_file_location('dem_engine_speed', HERE / 'dem_engine_speed.py')
    module = importlib.util.module_from_spec(spec)  # type: ignore[arg-type]
    spec.loader.exec_module(module)  # type: ignore[union-attr]
    return module


def write_data(path: Path, state: SimState, lo: np.ndarray, hi: np.ndarray,
               density: float) -> None:
    """LIGGGHTS data file (atom_style granular: id type diameter density x y z)."""
    head = [f'LIGGGHTS data: {state.n} spheres from dempath', '', f'{state.n} atoms',
            '2 atom types', *(f'{cmd.fmt(lo[k])} {cmd.fmt(hi[k])} {a}lo {a}hi'
                              for k, a in enumerate('xyz')), '', 'Atoms', '']
    rows = [f'{k + 1} 1 {cmd.fmt(2 * r)} {cmd.fmt(density)} {p[0]:.9g} {p[1]:.9g} {p[2]:.9g}'
            for k, (p, r) in enumerate(zip(state.positions, state.radii, strict=True))]
    path.write_text('\n'.join(head + rows) + '\n')


def liggghts_run(sb: ModuleType, state: SimState, tip: np.ndarray, dt: float, steps: int,
                 nprocs: int, workdir: Path) -> dict[str, float]:
    """The same bed, tool and steps on LIGGGHTS; particle-steps/s from its loop time.

    The box is centred on the bed's median in X and Z, so that the processor cut (`processors *
    1 *`) splits the particles evenly (an off-centre box gave 72 % / 28 % on 2 processes).
    Rolling resistance follows sb.PARAMS (see `--no-rolling`).
    """
    params = sb.PARAMS
    tris = read_stl(sb.CHISEL) + tip
    travel = np.array([0.0, 0.0, 1.0]) * dt * (steps + 40)
    lo = np.minimum(np.array(sb.BIN_LO), tris.reshape(-1, 3).min(axis=0)) - 0.02
    hi = np.maximum(np.array(sb.BIN_HI), tris.reshape(-1, 3).max(axis=0) + travel) + 0.02
    mid = np.median(state.positions, axis=0)
    half = np.maximum(mid - lo, hi - mid)
    lo[[0, 2]], hi[[0, 2]] = (mid - half)[[0, 2]], (mid + half)[[0, 2]]
    write_data(workdir / 'bed.data', state, lo, hi, params.materials[0].density)
    cmd.write_ascii_stl(str(workdir / 'tool.stl'), tris.tolist(), 'chisel')
    walls = [('x', sb.BIN_LO[0]), ('x', sb.BIN_HI[0]), ('y', sb.BIN_LO[1]), ('z', sb.BIN_LO[2]),
             ('z', sb.BIN_HI[2])]  # box_walls(open_top=True)
    lines = ['atom_style granular', 'atom_modify map array', 'boundary f f f', 'newton off',
             'communicate single vel yes', 'units si', 'soft_particles yes',
             'processors * 1 *',  # never split along Y: the box is tall for the tool only
             'hard_particles yes', 'read_data bed.data',
             f'neighbor {cmd.fmt(params.skin * sb.RADIUS)} bin',  # dempath's skin
             'neigh_modify delay 0',
             *cmd.materials(params), *cmd.pair_style(params), *cmd.gravity(params),
             f'timestep {cmd.fmt(dt)}', 'fix integr all nve/sphere',
             *[cmd.plane_wall(f'w{k}', params, a, off, 1) for k, (a, off) in enumerate(walls)],
             'fix tool all mesh/surface/stress file tool.stl type 2',
             cmd.mesh_wall('toolwall', params, ['tool']),
             'fix mv all move/mesh mesh tool linear 0 0 1',
             'thermo_style custom step atoms ke', 'thermo_modify lost ignore norm no',
             'thermo 1000', 'run 20', f'run {steps}']
    (workdir / 'in.bench').write_text('\n'.join(lines) + '\n')
    out = run_deck(workdir / 'in.bench', nprocs=nprocs)
    text = out.log_path.read_text(errors='replace')
    loops = [float(x.split()[3]) for x in text.splitlines() if x.startswith('Loop time of')]
    atoms = int(text.split('Loop time of')[-1].split('with')[1].split()[0])
    nlocal = text.split('Nlocal:')[-1].split()  # ave, 'ave', max, 'max', ...
    return {'liggghts_seconds': loops[-1], 'liggghts_particles': atoms,
            'liggghts_particle_steps_per_s': atoms * steps / loops[-1],
            'liggghts_nprocs': nprocs, 'liggghts_rolling': params.rolling_enabled,
            'liggghts_nlocal_max_over_ave': float(nlocal[2]) / float(nlocal[0])}


def cross_engine(args: argparse.Namespace, workdir: Path) -> dict[str, dict[str, object]]:
    """Cross-engine comparison of ``--cross-scene`` for each of ``--variants`` (see
    dempath_sim.validation.cross_engine and .effect_variants): variant -> summary."""
    from dempath_sim.scene import load_scene
    from dempath_sim.validation.cross_engine import run_cross_engine
    from dempath_sim.validation.effect_variants import variant_scene

    fill = 'shared_packing' if args.shared_packing else args.fill
    cache = args.cache_dir or workdir / 'packings'
    scene = load_scene(args.cross_scene)
    out: dict[str, dict[str, object]] = {}
    for variant in args.variants:
        t0 = time.monotonic()
        # The upper strength keeps the plain names (earlier results directories stay valid).
        label = variant if args.strength == 'upper' or variant == 'base' \
            else f'{variant}-{args.strength}'
        results = None if args.results_dir is None else args.results_dir / label
        report = run_cross_engine(variant_scene(scene, variant, args.strength),
                                  list(range(1, args.seeds + 1)), workdir / label,
                                  args.nprocs, cache_dir=cache, fill=fill, results_dir=results)
        out[label] = {**report.summary(), 'wall_s': time.monotonic() - t0}
        log.info('cross-engine %s: D/S %s', label,
                 ', '.join(f'{k} {v:.2f}' for k, v in report.ratios.items()))
    return out


def _variants(text: str) -> list[str]:
    """``--variants``: comma-separated names of effect_variants.VARIANTS, or ``all``."""
    from dempath_sim.validation.effect_variants import VARIANTS

    names = list(VARIANTS) if text == 'all' else [v for v in text.split(',') if v]
    bad = [v for v in names if v not in VARIANTS]
    if bad or not names:
        msg = f'{text!r}: use all or names among {", ".join(VARIANTS)}'
        raise argparse.ArgumentTypeError(msg)
    return names


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line options."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--steps', type=int, default=600)
    parser.add_argument('--layers', type=int, default=21, help='>= 45,000 spheres after the slot')
    parser.add_argument('--settle-steps', type=int, default=4000)
    parser.add_argument('--np', dest='nprocs', type=int, default=2)
    parser.add_argument('--cross-scene', default='builtin:tiny')
    parser.add_argument('--seeds', type=int, default=3, help='packing seeds 1..N per engine')
    parser.add_argument('--skip-cross', action='store_true')
    parser.add_argument('--no-rolling', action='store_true',
                        help='speed part without rolling resistance, in BOTH engines')
    parser.add_argument('--sleep', action='store_true',
                        help="dempath's grains at rest sleep (engine/sleep.py: changes results "
                             'slightly; the figure with the result-changing saving on)')
    parser.add_argument('--local-rebuild', action='store_true',
                        help='dempath keeps its neighbour list while grains moved together '
                             '(engine/rebuild.py: same contacts, sums in another order)')
    parser.add_argument('--skip-speed', action='store_true',
                        help='only the cross-engine part (speed keys are NaN)')
    parser.add_argument('--fill', choices=('shared_pour', 'insert_pack', 'shared_packing'),
                        default='shared_pour',
                        help="LIGGGHTS's bed in the cross-engine part: settle dempath's loose "
                             'pour of each seed (default), pour its own with insert/pack, or '
                             "start from dempath's settled packing")
    parser.add_argument('--shared-packing', action='store_true', help='same as --fill '
                        'shared_packing')
    parser.add_argument('--cache-dir', type=Path, default=None,
                        help="dempath's packing cache for the cross-engine part")
    parser.add_argument('--results-dir', type=Path, default=None,
                        help="save both engines' SimResults of the cross-engine part here")
    parser.add_argument('--variants', type=_variants, default=['base'],
                        help='cross-engine physics: base and/or candidates of the effects '
                             'library at its upper strength, comma-separated, or all '
                             '(dempath_sim.validation.effect_variants)')
    parser.add_argument('--strength', choices=('upper', 'lower'), default='upper',
                        help="the candidates' strength: the library's upper (default) or "
                             'lower run')
    parser.add_argument('--json-out', type=Path, default=None,
                        help='also write the JSON (with the command) to this file')
    return parser.parse_args(argv)


def speed(args: argparse.Namespace, work: Path) -> dict[str, object]:
    """Both engines on the settled >= 45,000-sphere bed with the tool passing."""
    numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))
    sb = speed_bench()
    state, tip = sb.insert_tool(sb.settled_bed(args.layers, args.settle_steps), depth=0.04,
                                tip_z=0.08)
    log.info('bed: %d spheres after the tool slot', state.n)
    if args.no_rolling:  # after the (cached) settle; timed_run and liggghts_run read sb.PARAMS
        sb.PARAMS = sb.without_rolling(sb.PARAMS)
    sleep = SleepSettings() if args.sleep else None
    dem = sb.timed_run(state.subset(np.ones(state.n, bool)), tip, args.steps, sb.PARAMS.skin,
                       sleep, args.local_rebuild)
    lig = liggghts_run(sb, state, tip, dem['dt'], args.steps, args.nprocs, work)
    per_particle = dem['particle_bytes'] + dem['pair_bytes'] * dem['pairs'] / dem['particles']
    log.info('dempath %.3g, LIGGGHTS %.3g particle-steps/s', dem['particle_steps_per_s'],
             lig['liggghts_particle_steps_per_s'])
    return {'particles': dem['particles'], 'steps': args.steps, 'dt_s': dem['dt'],
            'dempath_threads': numba.get_num_threads(), 'rolling': not args.no_rolling,
            'dempath_sleep': args.sleep, 'dempath_asleep_at_end': dem['asleep_at_end'],
            'dempath_local_rebuild': args.local_rebuild, 'dempath_rebuilds': dem['rebuilds'],
            'dempath_pair_evaluations_per_step': dem['pair_evaluations_per_step'],
            'dempath_particle_steps_per_s': dem['particle_steps_per_s'],
            'dempath_seconds': dem['seconds'], 'dempath_cpu_seconds': dem['cpu_seconds'], **lig,
            'ratio': dem['particle_steps_per_s'] / lig['liggghts_particle_steps_per_s'],
            'bytes_per_particle': per_particle}


def main() -> None:
    """Run both engines and print the JSON line."""
    args = parse_args()
    logging.basicConfig(level=logging.INFO, format='%(message)s')
    ensure_liggghts(install=True)
    work = Path(tempfile.mkdtemp(prefix='dem_vs_liggghts_'))
    nan = math.nan
    result: dict[str, object] = {
        'particles': nan, 'steps': nan, 'dempath_particle_steps_per_s': nan,
        'liggghts_particle_steps_per_s': nan, 'ratio': nan, 'bytes_per_particle': nan,
        'cross_engine_ratio': nan}
    if not args.skip_speed:
        result.update(speed(args, work))
    if not args.skip_cross:
        variants = cross_engine(args, work / 'cross')
        first = next(iter(variants.values()))
        worst = max(float(str(v['cross_engine_ratio'])) for v in variants.values())
        result.update({'cross_engine_ratio': worst,
                       'cross_engine': first, 'cross_scene': args.cross_scene,
                       'cross_fill': first['fill'], 'cross_nprocs': args.nprocs,
                       'cross_strength': args.strength})
        if len(variants) > 1:
            result['cross_variants'] = variants
    result['command'] = ' '.join(['.venv/bin/python bench/dem_vs_liggghts.py', *sys.argv[1:]])
    text = json.dumps(result, default=float)
    if args.json_out is not None:
        args.json_out.write_text(json.dumps(result, default=float, indent=1) + '\n')
    print(text)


if __name__ == '__main__':
    main()
