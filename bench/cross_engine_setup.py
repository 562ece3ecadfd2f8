"""Cross-engine check that cannot pass by construction: dempath against a hand-written deck.

The reference is the LIGGGHTS 3.8 deck in ``src/dempath_sim/dempath_sim/data/decks/leaning_tine``,
written by hand as LIGGGHTS users set a bin up (nothing of dempath's deck generator or fill):
random ``insert/pack``, the grains overlapping the tine deleted, 0.4 s settle with the tine in
place, ``read_data`` and a 0.06 s re-settle, the pass at 1 m/s. Two dempath set-ups are compared
with it, packing seed by packing seed:

- ``same_bed``: dempath's engine from the deck's own settled bed of the seed, the tine in place
  and the same re-settle (``validation.deck_setup.same_bed_run``): isolates the engines.
- ``same_bed_cold``: the same without the re-settle: the pass starts from the bed as read,
  every contact without history (how much the contact history at the start matters).
- ``dempath``: dempath's own set-up of the same bin, the scene file ``leaning_tine.yaml``
  through ``run_scene`` (its fill, markers, tool placement): what a user gets from the deck's
  input numbers.
- ``dempath_measured``: the same with ``leaning_tine_measured.yaml``, the bin as the deck's
  settled beds measure (95 mm deep, 1018 kg/m^3 inside, the tip 65 mm below the surface;
  ``fill.count: surface``): what a user gets from the deck's measured bed.
- ``dempath_poured``: the same bin poured the way the deck pours it, around the standing tine
  (``leaning_tine_poured.yaml``, ``tool.placement: poured``).
- any set-up with ``_default`` appended (``same_bed_default``, ``dempath_poured_default``): the
  same with the scene file's own contact law instead of LIGGGHTS 3.8's (``same_physics``), e.g.
  dempath's default forms as a scene written without ``sim`` keys runs them.

``--deck raked_tine`` takes the second hand-written deck (``data/decks/raked_tine``: a 35 mm bar
leaning 25 deg through 120 mm of 7 / 8 mm sand, issue 29) with its own scene and marker grid
(X = 0, +-50 mm; Z = 150-350 mm); its only scene file (``raked_tine.yaml``) is poured around the
tine, so ``dempath`` and ``dempath_poured`` are the same set-up there.

Every run is reduced by the same rules (``deck_setup.deck_stats``): axis and side markers' mean
displacement over time, the side markers' outward motion, the mean draft. For each set-up and
statistic, D / S against the deck (D: difference of the seed means, S: pooled seed spread, RMS
over time; ``validation.cross_engine.compare``). Each run is cached under ``--work`` (the deck's
outputs, one ``.npz`` of figures per run), so an interrupted bench resumes. Last line: one JSON
object.

    .venv/bin/python bench/cross_engine_setup.py [--seeds 4 | --seed-list 2,3]
        [--variants base,rolling,cohesion | all] [--setups same_bed,dempath] [--np 2] [--work DIR]
        [--deck leaning_tine | raked_tine] [--json-out FILE]

``--seed-list`` runs the given seeds only (several processes can fill one cache in parallel,
each with its own seeds); with fewer than two seeds the JSON gives the runs' figures without
D / S.
"""

from __future__ import annotations

import argparse
import json
import logging
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from dempath_sim.liggghts.install import ensure_liggghts
from dempath_sim.runs import RunOptions, run_scene
from dempath_sim.validation.cross_engine import compare, same_physics
from dempath_sim.validation.deck_setup import (
    DECKS,
    RESETTLE_S,
    VARIANTS,
    Deck,
    DeckStats,
    deck_frames,
    deck_stats,
    result_frames,
    run_deck,
    same_bed_run,
    scene_for,
)

log = logging.getLogger('bench')
STATS = ('axis', 'lateral', 'outward')
DEFAULT_LAW = '_default'  # set-up suffix: the scene's own contact law, not same_physics


def _save(path: Path, stats: DeckStats, extra: dict[str, Any]) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix('.tmp.npz')
    np.savez(tmp, times=stats.times, axis=stats.axis, lateral=stats.lateral,
             outward=stats.outward, draft=stats.draft,
             meta=json.dumps({'markers': stats.markers, **extra}))
    tmp.replace(path)


def _load(path: Path) -> tuple[DeckStats, dict[str, Any]]:
    with np.load(path) as d:
        meta = json.loads(str(d['meta']))
        return DeckStats(d['times'], d['axis'], d['lateral'], d['outward'], float(d['draft']),
                         meta.pop('markers')), meta


def _one_run(setup: str, variant: str, seed: int, work: Path, nprocs: int,
             deck: Deck) -> DeckStats:
    """Figures of one run, from the cache or by running it."""
    path = work / 'stats' / f'{setup}-{variant}-s{seed}.npz'
    if path.exists():
        return _load(path)[0]
    t0 = time.monotonic()
    base = setup.removesuffix(DEFAULT_LAW)
    scene = scene_for(variant, seed, deck.scene_file(base if base in deck.scenes else 'dempath'))
    if not setup.endswith(DEFAULT_LAW):
        scene = same_physics(scene)
    extra: dict[str, Any] = {}
    if setup == 'liggghts':
        run = work / 'liggghts' / f'seed{seed}' / variant
        if not (run / 'end.dump').exists():  # the deck's last output: the run is complete
            run_deck(seed, variant, work / 'liggghts', nprocs, deck)
        stats = deck_stats(deck_frames(run), deck.mean_r, deck.marker_z)
    elif base in ('same_bed', 'same_bed_cold'):
        if not (work / 'liggghts' / f'seed{seed}' / 'bed.data').exists():
            run_deck(seed, variant, work / 'liggghts', nprocs, deck)
        frames = same_bed_run(work / 'liggghts' / f'seed{seed}' / 'bed.data', scene,
                              RESETTLE_S if base == 'same_bed' else 0.0,
                              top_zone=deck.top_zone)
        stats = deck_stats(frames, deck.mean_r, deck.marker_z)
    else:
        scene = replace(scene, output=replace(scene.output, snapshot_interval_s=0.01))
        result = run_scene(scene, RunOptions(cache_dir=work / 'packings'))
        stats = deck_stats(result_frames(result, deck.top_zone), deck.mean_r, deck.marker_z)
        extra['fill'] = {k: v for k, v in result.meta.get('fill', {}).items()
                         if isinstance(v, int | float)}
    extra['wall_s'] = time.monotonic() - t0
    _save(path, stats, extra)
    log.info('%s %s seed %d: outward %.1f mm, draft %.2f N (%.0f s)', setup, variant, seed,
             1e3 * stats.outward[-1], stats.draft, extra['wall_s'])
    return stats


def _summary(runs: list[DeckStats]) -> dict[str, Any]:
    out = np.array([s.outward[-1] for s in runs])
    draft = np.array([s.draft for s in runs])
    return {'axis_end_mm': [round(1e3 * float(s.axis[-1]), 2) for s in runs],
            'lateral_end_mm': [round(1e3 * float(s.lateral[-1]), 2) for s in runs],
            'outward_end_mm': [round(1e3 * x, 2) for x in out],
            'outward_end_mean_mm': round(1e3 * float(out.mean()), 2),
            'draft_n': [round(x, 3) for x in draft],
            'draft_mean_n': round(float(draft.mean()), 3)}


def _against(runs: list[DeckStats], deck: list[DeckStats], seeds: list[int]) -> dict[str, Any]:
    report = compare(runs, deck, seeds, names=STATS)
    return {'ratios': {k: round(v, 3) for k, v in report.ratios.items()},
            'difference': report.difference, 'spread': report.spread,
            'ratio_max': round(report.cross_engine_ratio, 3)}


def main() -> None:
    """Run (or read from the cache) every set-up, variant and seed; print one JSON line."""
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--seeds', type=int, default=4, help='seeds 1..N')
    ap.add_argument('--seed-list', help='comma-separated seeds (instead of --seeds)')
    ap.add_argument('--variants', default='base',
                    help=f'comma-separated among {", ".join(VARIANTS)}, or all')
    ap.add_argument('--setups', default='same_bed,dempath')
    ap.add_argument('--np', type=int, default=2, dest='nprocs')
    ap.add_argument('--work', type=Path,
                    default=Path.home() / '.cache' / 'dempath' / 'cross_engine_setup')
    ap.add_argument('--deck', choices=sorted(DECKS), default='leaning_tine')
    ap.add_argument('--json-out', type=Path)
    args = ap.parse_args()
    logging.basicConfig(level=logging.INFO, format='%(message)s')
    ensure_liggghts()
    t0 = time.monotonic()
    seeds = ([int(s) for s in args.seed_list.split(',')] if args.seed_list
             else list(range(1, args.seeds + 1)))
    deck = DECKS[args.deck]
    figures: dict[str, Any] = {'bench': 'cross_engine_setup', 'scene': deck.name,
                               'seeds': seeds, 'variants': {}}
    variants = list(VARIANTS) if args.variants == 'all' else args.variants.split(',')
    unknown = [v for v in variants if v not in VARIANTS]
    if unknown:
        ap.error(f'--variants: {", ".join(unknown)}: not a variant of the deck '
                 f'({", ".join(VARIANTS)})')
    for variant in variants:
        ref = [_one_run('liggghts', variant, s, args.work, args.nprocs, deck) for s in seeds]
        entry: dict[str, Any] = {'liggghts': _summary(ref)}
        for setup in args.setups.split(','):
            runs = [_one_run(setup, variant, s, args.work, args.nprocs, deck) for s in seeds]
            entry[setup] = _summary(runs)
            if len(seeds) > 1:
                entry[setup].update(_against(runs, ref, seeds))
        figures['variants'][variant] = entry
    if len(seeds) > 1:  # per set-up, the largest D / S over every variant and statistic
        entries = figures['variants'].values()
        figures['ratio_max'] = {setup: max(e[setup]['ratio_max'] for e in entries)
                                for setup in args.setups.split(',')}
    figures['wall_s'] = round(time.monotonic() - t0, 1)
    text = json.dumps(figures)
    if args.json_out is not None:
        args.json_out.write_text(json.dumps(figures, indent=1) + '\n')
    print(text)


if __name__ == '__main__':
    main()
