"""Is the sleeping far field harmless? The same scene on dempath's engine with sleeping off and on.

For each packing seed and physics variant the scene's pass runs twice on the same settled bed,
``sim.sleep: false`` and ``true``, as the signature library runs it (``run_pass``: whole-bed
frames every 0.02 s, the re-settle against the tool, the pass). Two sets of statistics are
compared, each as D / S (D: difference of the seed means of off and on; S: the pooled seed
spread of one run; see ``dempath_sim.validation.cross_engine``):

* the cross-engine statistics: the mean displacement of the axis and lateral markers over time
  and the mean draft force (``marker_statistics``);
* the diagnosis's group statistics: per marker group (axis, left, right), time window and axis
  (outward, vertical, forward) the displacement of the bed at the marker's start, and the draft
  per window (``dempath_diagnose.decision.statistics.model_statistics``, the vector the
  emulator and the verdict read), each component's D / S; the largest, how many exceed 1 and
  the median, beside what two identical set-ups give with as many seeds (D / S = sqrt(2 / n) |t|,
  t a Student t of 2 n - 2 degrees of freedom: with 3 seeds 29 % of the components exceed 1 by
  chance, so "every component below 1" cannot be asked of a few seeds).

Also the pair evaluations of the pass (a count: what sleeping saves in work) and the drive's
wall time (loaded machines: a figure, not a timing). Runs are saved in ``--results-dir`` and
read back, so an interrupted bench resumes. Last line: one JSON object.

    .venv/bin/python bench/sleep_effect.py --results-dir /tmp/sleep_effect \\
        [--scene builtin:reduced_1ms] [--seeds 1001,1002,1003] [--variants base]
"""

from __future__ import annotations

import argparse
import json
import logging
import math
import sys
import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from scipy import stats

from dempath_diagnose.decision.statistics import build_layout, model_statistics
from dempath_diagnose.library.simulator import run_pass, tool_geometry
from dempath_diagnose.records import PassRecord
from dempath_sim.runs.markers import grid_xz
from dempath_sim.scene import SceneSpec, load_scene
from dempath_sim.validation.cross_engine import compare
from dempath_sim.validation.effect_variants import VARIANTS, variant_scene

log = logging.getLogger('bench')
MODES = ('off', 'on')


@dataclass(frozen=True)
class PassStats:
    """The cross-engine statistics of one pass record (the shape ``compare`` reads)."""

    times: NDArray[np.float64]
    axis: NDArray[np.float64]
    lateral: NDArray[np.float64]
    draft: float


def with_sleep(scene: SceneSpec, on: bool, scale: float = 1.0) -> SceneSpec:
    """``scene`` with ``sim.sleep`` and ``sim.sleep_scale`` set."""
    return replace(scene, sim=replace(scene.sim, sleep=on, sleep_scale=scale if on else 1.0))


def marker_starts(scene: SceneSpec,
                  rec: PassRecord) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """(numbers (m,), starts (m, 3)): the scene's marker grid, each marker the record's particle
    nearest its grid point on the settled surface."""
    numbers, xz = grid_xz(scene.markers)
    surface = float(rec.meta['surface_height_m'])
    grid = np.column_stack([xz[:, 0], np.full(len(xz), surface), xz[:, 1]])
    near = [int(np.argmin(np.linalg.norm(rec.start - p, axis=1))) for p in grid]
    return np.asarray(numbers, np.int64), rec.start[near]


def pass_stats(rec: PassRecord, starts: NDArray[np.float64], tool_x: float,
               half: float) -> PassStats:
    """Axis / lateral mean displacement of the marker particles over time, mean draft."""
    idx = [int(np.argmin(np.linalg.norm(rec.start - p, axis=1))) for p in starts]
    disp = np.linalg.norm(rec.positions[:, idx].astype(np.float64) - starts[None], axis=2)
    axis = np.abs(starts[:, 0] - tool_x) <= half
    stop = float(rec.meta.get('tool_stop_s', rec.force_times[-1]))
    moving = (rec.force_times > 0.0) & (rec.force_times <= stop)
    return PassStats(rec.times, disp[:, axis].mean(axis=1), disp[:, ~axis].mean(axis=1),
                     float(np.mean(-rec.tool_force[moving, 2])))


def one_pass(scene: SceneSpec, variant: str, seed: int, mode: str, folder: Path,
             cache_dir: Path | None, scale: float = 1.0) -> PassRecord:
    """The pass of ``variant`` on ``seed`` with sleeping ``mode`` (thresholds times ``scale``):
    read back or run and saved."""
    tag = mode if mode == 'off' or scale == 1.0 else f'{mode}-x{scale:g}'
    path = folder / f'{variant}-{tag}-s{seed}.npz'
    if path.is_file():
        return PassRecord.load(path)
    t0 = time.monotonic()
    run = with_sleep(variant_scene(scene, variant), mode == 'on', scale)
    rec = run_pass(run, seed, {}, cache_dir=cache_dir)
    rec.save(path)
    log.info('%s %s seed %d: %.0f s, %d pair evaluations in the pass', variant, mode, seed,
             time.monotonic() - t0, rec.meta.get('drive_pair_evaluations', 0))
    return rec


def group_ratios(scene: SceneSpec, recs: dict[str, list[PassRecord]],
                 numbers: NDArray[np.int64],
                 starts: NDArray[np.float64]) -> dict[str, object]:
    """D / S of every component of the diagnosis's group-statistics vector, off against on."""
    tool_x, half, cube = tool_geometry(scene)
    first = recs['off'][0]
    end = float(first.times[-1])
    stop = float(first.meta.get('tool_stop_s', end))
    layout = build_layout(numbers, starts, tool_x, half, end, stop)
    vec = {m: np.array([model_statistics(r, layout, cube, True).vector for r in recs[m]])
           for m in MODES}
    d = np.abs(np.nanmean(vec['off'], axis=0) - np.nanmean(vec['on'], axis=0))
    s = np.sqrt((np.nanvar(vec['off'], axis=0, ddof=1) + np.nanvar(vec['on'], axis=0, ddof=1))
                / 2)
    ratio = np.where(s > 0, d / np.where(s > 0, s, 1.0), np.where(d > 0, np.inf, 0.0))
    names = layout.names(True)
    worst = int(np.nanargmax(ratio))
    n = len(recs['off'])
    return {'components': len(ratio), 'largest': float(ratio[worst]),
            'largest_name': names[worst], 'above_1': int(np.sum(ratio > 1.0)),
            'median': float(np.nanmedian(ratio)),
            'null_fraction_above_1': null_fraction_above_1(n), 'null_median': null_median(n)}


def null_fraction_above_1(n: int) -> float:
    """P(D / S > 1) for one statistic of two identical set-ups with n seeds each: D / S =
    sqrt(2 / n) |t| with t a Student t of 2 n - 2 degrees of freedom (cross_engine's note)."""
    return float(2.0 * stats.t.sf(math.sqrt(n / 2.0), 2 * n - 2))


def null_median(n: int) -> float:
    """The median D / S of one statistic of two identical set-ups with n seeds each."""
    return float(math.sqrt(2.0 / n) * stats.t.ppf(0.75, 2 * n - 2))


def variant_figures(scene: SceneSpec, variant: str, seeds: list[int], folder: Path,
                    cache_dir: Path | None, scale: float = 1.0) -> dict[str, object]:
    """Both modes on every seed, and the off/on comparison."""
    recs = {m: [one_pass(scene, variant, s, m, folder, cache_dir, scale) for s in seeds]
            for m in MODES}
    tool_x, half, _ = tool_geometry(scene)
    numbers, starts = marker_starts(scene, recs['off'][0])
    stats = {m: [pass_stats(r, marker_starts(scene, r)[1], tool_x, half) for r in recs[m]]
             for m in MODES}
    report = compare(stats['off'], stats['on'], seeds)
    evals = {m: [float(r.meta.get('drive_pair_evaluations', 0)) for r in recs[m]] for m in MODES}
    wall = {m: [float(r.meta.get('drive_wall_s', 0.0)) for r in recs[m]] for m in MODES}
    out: dict[str, object] = {
        'seeds': seeds, 'ratios': report.ratios, 'cross_engine_statistics_ratio':
        report.cross_engine_ratio, 'difference': report.difference, 'spread': report.spread,
        'draft_off_n': [s.draft for s in stats['off']],
        'draft_on_n': [s.draft for s in stats['on']],
        'group_statistics': group_ratios(scene, recs, numbers, starts),
        'pair_evaluations_on_over_off': float(np.sum(evals['on']) / max(np.sum(evals['off']), 1)),
        'drive_wall_s': wall}
    log.info('%s: D/S %s; group statistics %s; pair evaluations on/off %.3f', variant,
             ', '.join(f'{k} {v:.2f}' for k, v in report.ratios.items()),
             out['group_statistics'], out['pair_evaluations_on_over_off'])
    return out


def _ints(text: str) -> list[int]:
    return [int(x) for x in text.split(',') if x]


def _variants(text: str) -> list[str]:
    names = list(VARIANTS) if text == 'all' else [v for v in text.split(',') if v]
    bad = [v for v in names if v not in VARIANTS]
    if bad or not names:
        msg = f'{text!r}: use all or names among {", ".join(VARIANTS)}'
        raise argparse.ArgumentTypeError(msg)
    return names


def main() -> None:
    """Run (or read back) every pass and print the JSON line."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--scene', default='builtin:reduced_1ms')
    parser.add_argument('--seeds', type=_ints, default=[1001, 1002, 1003],
                        help='packing seeds (the shipped reduced_1ms beds: 1, 1001-1003)')
    parser.add_argument('--variants', type=_variants, default=['base'],
                        help='base and/or candidates of the effects library, or all')
    parser.add_argument('--results-dir', type=Path, required=True)
    parser.add_argument('--cache-dir', type=Path, default=None, help='packing cache')
    parser.add_argument('--json-out', type=Path, default=None)
    parser.add_argument('--sleep-scale', type=float, default=1.0,
                        help='the sleep thresholds times this (sim.sleep_scale)')
    parser.add_argument('--only', choices=MODES, default=None,
                        help='only run the passes of one mode (e.g. in a second process) and '
                             'stop; a later call without it compares')
    args = parser.parse_args()
    logging.basicConfig(level=logging.INFO, format='%(message)s')
    scene = load_scene(args.scene)
    if args.only is not None:
        for variant in args.variants:
            folder = args.results_dir / variant
            folder.mkdir(parents=True, exist_ok=True)
            for seed in args.seeds:
                one_pass(scene, variant, seed, args.only, folder, args.cache_dir,
                         args.sleep_scale)
        print(json.dumps({'scene': scene.name, 'only': args.only, 'done': True}))
        return
    results: dict[str, object] = {}
    worst = 0.0
    for variant in args.variants:
        folder = args.results_dir / variant
        folder.mkdir(parents=True, exist_ok=True)
        fig = variant_figures(scene, variant, args.seeds, folder, args.cache_dir,
                              args.sleep_scale)
        results[variant] = fig
        group = fig['group_statistics']
        assert isinstance(group, dict)
        worst = max(worst, float(str(fig['cross_engine_statistics_ratio'])),
                    float(group['largest']))
    out = {'scene': scene.name, 'sleep_scale': args.sleep_scale, 'variants': results,
           'largest_ratio': worst,
           'harmless': bool(worst <= 1.0) if math.isfinite(worst) else False,
           'command': ' '.join(['.venv/bin/python bench/sleep_effect.py', *sys.argv[1:]])}
    text = json.dumps(out, default=float)
    if args.json_out is not None:
        args.json_out.write_text(json.dumps(out, default=float, indent=1) + '\n')
    print(text)


if __name__ == '__main__':
    main()
