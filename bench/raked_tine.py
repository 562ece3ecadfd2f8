"""Issue 29's whole bin on both engines: the forward-raked tine, marker statistics by seed.

The bin of ``data/decks/raked_tine`` (300 x 500 mm, 120 mm of 7 / 8 mm sand, a 35 mm bar
leaning 25 deg with its tip leading, 80 mm deep, 1 m/s over 330 mm; about 47,000 grains) on
LIGGGHTS 3.8 (the hand-written deck, one MPI rank per run) and on dempath (the scene file
``raked_tine.yaml`` as written, through ``run_scene``: its own pour around the tine, its own
contact law), seed by seed. Each run keeps the grains of the deck's surface zone (X within 90 mm
of the axis, Z 120-380 mm, centre above Y = -30 mm) every 0.01 s and the tine's force, cached
under ``--work`` (``liggghts/seed<k>/<variant>/`` as ``run.sh`` writes it; ``dempath/<variant>-
s<k>.npz``), so an interrupted bench resumes and several processes can fill one cache with
different ``--seed-list``s.

Every run is reduced by three marker rules on its own bed at t = 0 (grid X = 0, +-50 mm;
Z = 150 ... 350 mm every 50 mm): ``deck`` (``deck_setup.pick_markers``: centre within 12 mm
horizontally and within one mean radius of the highest centre there), and dempath's own
``runs.markers`` rules ``exposed`` (the default: top within one diameter of the local surface)
and ``top`` (centre within one radius of the highest centre). Figures at the end of the pass
(the last output), per seed: the side markers' outward / forward / vertical motion and the
axis markers' lateral (|dX|) / vertical / forward motion [mm], the markers' depth below the
highest grain top near them at t = 0 [mm], and the draft (mean -F_z while the tine runs
steady, 0.10-0.33 s) [N]. Across seeds: mean, SD; between engines D / S (D: difference of the
means, S: the pooled SD), for each rule.

    .venv/bin/python bench/raked_tine.py [--seeds 6 | --seed-list 1,3] [--engines liggghts,dempath]
        [--variants base | all | a,b] [--rules deck,exposed,top] [--work DIR] [--json-out FILE]
        [--run-only | --cached-only]

``--run-only`` fills the cache and prints nothing but the runs' log; ``--cached-only`` runs
nothing and reports the runs already in the cache (each engine its own seeds). Last line: one
JSON object.
"""

from __future__ import annotations

import argparse
import json
import logging
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dempath_sim.runs import RunOptions, run_scene
from dempath_sim.runs.markers import select_markers
from dempath_sim.scene.spec import MarkerSpec
from dempath_sim.validation.deck_setup import (
    NEAR_M,
    RAKED_TINE,
    SIDE_X,
    VARIANTS,
    Frames,
    deck_frames,
    pick_markers,
    read_dump,
    result_frames,
    run_deck,
    scene_for,
)

log = logging.getLogger('bench')
F64 = NDArray[np.float64]
DECK = RAKED_TINE
RULES = ('deck', 'exposed', 'top')
STEADY_S = (0.10, 0.33)  # s after the start: the tine at 1 m/s (50 mm at 10 m/s^2, 230 mm)
FIGURES = ('side_outward', 'side_forward', 'side_vertical', 'axis_lateral', 'axis_vertical',
           'axis_forward', 'side_depth', 'axis_depth', 'draft')


@dataclass(frozen=True)
class Run:
    """One pass: the surface zone's frames and the radii of its grains (by ``frames.ids``)."""

    frames: Frames
    radii: F64


def _liggghts_run(work: Path, seed: int, variant: str) -> Run:
    run = work / 'liggghts' / f'seed{seed}' / variant
    if not (run / 'end.dump').exists():  # the deck's last output: the run is complete
        t0 = time.monotonic()
        run_deck(seed, variant, work / 'liggghts', 1, DECK)
        log.info('liggghts %s seed %d: %.0f s', variant, seed, time.monotonic() - t0)
    frames = deck_frames(run)
    start = read_dump(run / 'start.dump')[0][1]
    by_id = dict(zip(start['id'].astype(np.int64).tolist(), start['radius'].tolist(),
                     strict=True))
    return Run(frames, np.array([by_id[int(i)] for i in frames.ids]))


def _dempath_run(work: Path, seed: int, variant: str) -> Run:
    path = work / 'dempath' / f'{variant}-s{seed}.npz'
    if not path.exists():
        t0 = time.monotonic()
        scene = scene_for(variant, seed, DECK.scene_file())
        scene = replace(scene, output=replace(scene.output, snapshot_interval_s=0.01))
        result = run_scene(scene, RunOptions(cache_dir=work / 'packings'))
        frames = result_frames(result, DECK.top_zone)
        by_id = dict(zip(result.snapshot_ids.tolist(), result.snapshot_radii.tolist(),
                         strict=True))
        fill = {k: v for k, v in result.meta.get('fill', {}).items()
                if isinstance(v, int | float)}
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix('.tmp.npz')
        np.savez_compressed(tmp, times=frames.times, ids=frames.ids,
                            positions=frames.positions.astype(np.float32), force=frames.force,
                            radii=np.array([by_id[int(i)] for i in frames.ids]),
                            meta=json.dumps({'fill': fill, 'wall_s': time.monotonic() - t0,
                                             'n_particles': result.meta.get('n_particles')}))
        tmp.replace(path)
        log.info('dempath %s seed %d: %.0f s', variant, seed, time.monotonic() - t0)
    with np.load(path) as d:
        frames = Frames(d['times'], d['ids'], d['positions'].astype(np.float64), d['force'])
        return Run(frames, d['radii'])


def _cached(work: Path, engine: str, seed: int, variant: str) -> bool:
    if engine == 'liggghts':
        return (work / 'liggghts' / f'seed{seed}' / variant / 'end.dump').exists()
    return (work / 'dempath' / f'{variant}-s{seed}.npz').exists()


def markers(run: Run, rule: str) -> dict[str, list[int]]:
    """Marker indices into the run's grains per group ('axis', 'left', 'right') by ``rule``."""
    start = run.frames.positions[0]
    if rule == 'deck':
        deck: dict[str, list[int]] = pick_markers(run.frames.ids, start, DECK.mean_r,
                                                  DECK.marker_z)
        return deck
    here = np.flatnonzero(np.all(np.isfinite(start), axis=1))
    index = np.arange(len(here), dtype=np.int64)
    out: dict[str, list[int]] = {}
    for group, side in (('right', 1), ('left', -1)):
        spec = MarkerSpec(rows=2, columns=len(DECK.marker_z), spacing_x_m=SIDE_X,
                          spacing_z_m=DECK.marker_z[1] - DECK.marker_z[0],
                          first_z_m=DECK.marker_z[0], side=side, pick=rule)
        sel = select_markers(start[here], run.radii[here], index, spec)
        picked = here[sel.particle_ids].tolist()
        out['axis'] = picked[:spec.columns]
        out[group] = picked[spec.columns:]
    return out


def figures(run: Run, rule: str) -> dict[str, float]:
    """The run's end-of-pass figures (module docstring) by marker rule ``rule``."""
    idx = markers(run, rule)
    p = run.frames.positions
    d = p[-1] - p[0]
    side = idx['left'] + idx['right']
    sign = np.array([-1.0] * len(idx['left']) + [1.0] * len(idx['right']))
    start = p[0]
    ok = np.all(np.isfinite(start), axis=1)

    def depth(group: list[int]) -> float:
        out = []
        for i in group:
            h = np.hypot(start[:, 0] - start[i, 0], start[:, 2] - start[i, 2])
            near = ok & (h < NEAR_M)
            top = np.max(start[near, 1] + run.radii[near])
            out.append(top - (start[i, 1] + run.radii[i]))
        return float(np.mean(out))

    t = run.frames.times
    steady = (t > STEADY_S[0] - 1e-9) & (t < STEADY_S[1] + 1e-9) & (t > 0)
    return {'side_outward': 1e3 * float(np.nanmean(sign * d[side, 0])),
            'side_forward': 1e3 * float(np.nanmean(d[side, 2])),
            'side_vertical': 1e3 * float(np.nanmean(d[side, 1])),
            'axis_lateral': 1e3 * float(np.nanmean(np.abs(d[idx['axis'], 0]))),
            'axis_vertical': 1e3 * float(np.nanmean(d[idx['axis'], 1])),
            'axis_forward': 1e3 * float(np.nanmean(d[idx['axis'], 2])),
            'side_depth': 1e3 * depth(side), 'axis_depth': 1e3 * depth(idx['axis']),
            'draft': float(-np.mean(run.frames.force[steady, 2]))}


def group(per_seed: list[dict[str, float]]) -> dict[str, Any]:
    """Mean and SD over seeds of each figure, and the per-seed values."""
    out: dict[str, Any] = {}
    for name in FIGURES:
        x = np.array([f[name] for f in per_seed])
        out[name] = {'mean': round(float(x.mean()), 2),
                     'sd': round(float(x.std(ddof=1)), 2) if len(x) > 1 else None,
                     'seeds': [round(float(v), 2) for v in x]}
    return out


def ratios(a: dict[str, Any], b: dict[str, Any]) -> dict[str, float | None]:
    """D / S of every figure between two groups (D: difference of the means, S: pooled SD)."""
    out: dict[str, float | None] = {}
    for name in FIGURES:
        sa, sb = a[name]['sd'], b[name]['sd']
        if sa is None or sb is None:
            out[name] = None
            continue
        s = float(np.sqrt((sa ** 2 + sb ** 2) / 2))
        out[name] = round(abs(a[name]['mean'] - b[name]['mean']) / s, 2) if s > 0 else None
    return out


def main() -> None:
    """Run (or read from the cache) every engine, variant and seed; print one JSON line."""
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--seeds', type=int, default=6, help='seeds 1..N')
    ap.add_argument('--seed-list', help='comma-separated seeds (instead of --seeds)')
    ap.add_argument('--engines', default='liggghts,dempath')
    ap.add_argument('--variants', default='base',
                    help=f'comma-separated among {", ".join(VARIANTS)}, or all')
    ap.add_argument('--rules', default=','.join(RULES))
    ap.add_argument('--work', type=Path,
                    default=Path.home() / '.cache' / 'dempath' / 'raked_bin')
    ap.add_argument('--json-out', type=Path)
    mode = ap.add_mutually_exclusive_group()
    mode.add_argument('--run-only', action='store_true')
    mode.add_argument('--cached-only', action='store_true')
    args = ap.parse_args()
    logging.basicConfig(level=logging.INFO, format='%(asctime)s %(message)s')
    seeds = ([int(s) for s in args.seed_list.split(',')] if args.seed_list
             else list(range(1, args.seeds + 1)))
    variants = list(VARIANTS) if args.variants == 'all' else args.variants.split(',')
    unknown = [v for v in variants if v not in VARIANTS]
    if unknown:
        ap.error(f'--variants: {", ".join(unknown)}: not a variant of the deck')
    engines = args.engines.split(',')
    loaders = {'liggghts': _liggghts_run, 'dempath': _dempath_run}
    report: dict[str, Any] = {'bench': 'raked_tine', 'seeds': seeds, 'variants': {}}
    for variant in variants:
        done = {e: [s for s in seeds
                    if not args.cached_only or _cached(args.work, e, s, variant)]
                for e in engines}
        runs = {e: [loaders[e](args.work, s, variant) for s in done[e]] for e in engines}
        if args.run_only:
            continue
        entry: dict[str, Any] = {'seeds': done}
        for rule in args.rules.split(','):
            groups = {e: group([figures(r, rule) for r in runs[e]]) for e in engines if runs[e]}
            entry[rule] = groups
            if len(groups) == 2:
                entry[rule]['d_over_s'] = ratios(groups[engines[1]], groups[engines[0]])
        report['variants'][variant] = entry
    if args.run_only:
        return
    text = json.dumps(report)
    if args.json_out is not None:
        args.json_out.write_text(json.dumps(report, indent=1) + '\n')
    print(text)


if __name__ == '__main__':
    main()
