"""Hidden-effect cases diagnosed against a scene's signature library (issue 13's proof).

Builds (or resumes) the scene's signature library through Dask, generates each hidden-effect
case with dempath_sim on a seed the library never used (its own bed, 1.5 mm noise per axis on
the markers), diagnoses it with the force and without, and scores the answers: top-1 correct,
confident wrong answers (a wrong effect named with probability > 0.5), inconclusive answers,
the Brier score and a reliability table of the top probability. Everything is cached under
``--root``: an interrupted bench resumes. The last line is one JSON object.

Usage: ``.venv/bin/python bench/diagnose.py [--scene reduced_1ms] [--root DIR] [--serial]``
(``--scene tiny`` for a quick check; ``--scene tiny_rivals`` for its own six cases, where
cohesion and rolling resistance are rivals, three held out; ``--library-only`` times the library
build alone, in wall and CPU seconds of the process tree; ``--budget N`` allows N simulations
beyond the library per diagnosis; ``--no-shared-settle`` and ``--rest-tolerance-m 0`` build the
library as before issue 30's design savings, for a paired comparison).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import time
from pathlib import Path
from typing import Any

import numpy as np

from dempath_diagnose.cli import diagnose_main
from dempath_diagnose.library.cases import HiddenCase, make_case
from dempath_diagnose.library.simulator import LIBRARY_CANDIDATES, load_scene, pass_travel_s
from dempath_diagnose.library.store import (
    LibrarySpec,
    build_library,
    covering_duration,
    library_state,
    serial_executor,
)
from dempath_sim.runs.rest import REST_TOLERANCE_M

NAMED = ('effect_missing', 'parameter_off')
OPEN = ('nothing_significant', 'inconclusive')


CASE_SEEDS = (7, 8, 9)  # beds the library never used, shared by cases (pours are dearest)


# The two-rivals scene's cases held out: written before any run of the scene's bench and never
# used to choose the separation step's constants (dempath_diagnose.separation).
HELD_OUT = frozenset({'rivals_control_b', 'rivals_cohesion_6e4', 'rivals_rolling_0.45'})


def rival_cases() -> list[HiddenCase]:
    """The two-rivals scene's cases (``tiny_rivals``, issue 32): cohesion and rolling resistance
    both raise its draft, so each is the other's rival; a control on each side."""
    coh, roll = 'cohesion.energy_density_j_m3', 'rolling_resistance.coefficient'
    either = ('effect_missing', 'parameter_off', 'inconclusive')
    return [
        HiddenCase('rivals_control', {}, '', (*OPEN[:1], 'inconclusive'), seed=CASE_SEEDS[0]),
        HiddenCase('rivals_cohesion_1e5', {coh: 1e5}, 'cohesion', either, seed=CASE_SEEDS[1]),
        HiddenCase('rivals_rolling_0.52', {roll: 0.52}, 'rolling_resistance', either,
                   seed=CASE_SEEDS[2]),
        HiddenCase('rivals_control_b', {}, '', (*OPEN[:1], 'inconclusive'), seed=CASE_SEEDS[1]),
        HiddenCase('rivals_cohesion_6e4', {coh: 6e4}, 'cohesion', either, seed=CASE_SEEDS[2]),
        HiddenCase('rivals_rolling_0.45', {roll: 0.45}, 'rolling_resistance', either,
                   seed=CASE_SEEDS[0]),
    ]


def cases_for(scene_name: str) -> list[HiddenCase]:
    """The hidden-effect cases: strong ones must be named; weak and control must not be.

    Case k runs on CASE_SEEDS[k % 3]: each case is diagnosed on its own, so sharing a bed
    between cases costs no independence within a case, and the three beds are poured once.
    ``tiny_rivals`` has its own cases (:func:`rival_cases`).
    """
    if scene_name == 'tiny_rivals':
        return rival_cases()
    strong = {'cohesion.energy_density_j_m3': 1e5}
    return [
        HiddenCase('control', {}, '', (*OPEN[:1], 'inconclusive'), seed=CASE_SEEDS[0]),
        HiddenCase('control_b', {}, '', (*OPEN[:1], 'inconclusive'), seed=CASE_SEEDS[1]),
        HiddenCase('tool_speed_1.5', {'tool_speed.speed_scale': 1.5}, 'tool_speed',
                   ('parameter_off',), seed=CASE_SEEDS[2]),
        HiddenCase('tool_speed_0.7', {'tool_speed.speed_scale': 0.7}, 'tool_speed',
                   ('parameter_off',), seed=CASE_SEEDS[0]),
        HiddenCase('cohesion_strong', strong, 'cohesion', ('effect_missing',), seed=CASE_SEEDS[1]),
        HiddenCase('cohesion_moderate', {'cohesion.energy_density_j_m3': 3e4}, 'cohesion',
                   ('effect_missing', 'inconclusive'), seed=CASE_SEEDS[2]),
        HiddenCase('tool_friction_x2', {'tool_friction.static_friction': 0.8,
                                        'tool_friction.dynamic_friction': 0.6}, 'tool_friction',
                   ('parameter_off', 'inconclusive', 'nothing_significant'), seed=CASE_SEEDS[0]),
        HiddenCase('particle_friction_0.5', {'particle_friction.static_friction': 0.5,
                                             'particle_friction.dynamic_friction': 0.42},
                   'particle_friction', ('parameter_off', 'inconclusive'), seed=CASE_SEEDS[1]),
        HiddenCase('rolling_x2', {'rolling_resistance.coefficient': 0.52}, 'rolling_resistance',
                   ('parameter_off', 'inconclusive'), seed=CASE_SEEDS[2]),
        HiddenCase('tool_speed_2', {'tool_speed.speed_scale': 2.0}, 'tool_speed',
                   ('parameter_off',), seed=CASE_SEEDS[1]),
        HiddenCase('too_weak_tool_friction', {'tool_friction.static_friction': 0.42,
                                              'tool_friction.dynamic_friction': 0.315}, '',
                   OPEN, seed=CASE_SEEDS[0]),
    ]


def score(case: HiddenCase, data: dict[str, Any]) -> dict[str, Any]:
    """Right / confident-wrong / inconclusive of one answer, and its Brier term."""
    verdict = data['verdict']
    top = data['ranking'][0]
    named = top['effect'] if verdict in NAMED else ''
    probs = {r['effect']: r['probability'] for r in data['ranking']}
    probs[''] = data['baseline']['probability']
    truth = case.truth
    brier = sum((p - (1.0 if k == truth else 0.0)) ** 2 for k, p in probs.items())
    correct = (named == truth) if verdict in NAMED else (
        verdict in case.verdicts and (verdict == 'nothing_significant' or not truth
                                      or truth in data['remaining']))
    return {'case': case.name, 'verdict': verdict, 'named': named, 'truth': truth,
            'top': top['effect'], 'top_p': top['probability'],
            'p_truth': probs.get(truth, 0.0), 'correct': bool(correct),
            'top1': top['effect'] == truth if truth else verdict == 'nothing_significant',
            'confident_wrong': bool(named and named != truth and top['probability'] > 0.5),
            'brier': brier, 'wall_s': data['wall_s']}


def adaptive_row(case: HiddenCase, data: dict[str, Any]) -> dict[str, Any]:
    """The answer on the library alone (before the extra simulations), scored like the final
    one, and what the budget bought."""
    adaptive = data.get('adaptive')
    if not adaptive:
        return {}
    before = adaptive['probabilities_before']
    ranked = sorted(((k, p) for k, p in before.items() if k != 'nothing'), key=lambda kp: -kp[1])
    old = {'verdict': adaptive['verdict_before'], 'wall_s': 0.0,
           'ranking': [{'effect': k, 'probability': p} for k, p in ranked],
           'baseline': {'probability': before['nothing']},
           'remaining': adaptive['remaining_before']}
    was = score(case, old)
    top, prior = data['ranking'][0], adaptive['top_before']
    value = case.overrides.get(f"{case.truth}.{top['strength']['parameter']}")
    fits = {}
    if value is not None:
        fits = {'true_strength': value, 'fitted': round(top['strength']['value'], 4),
                'fitted_sd': round(top['strength']['uncertainty'], 4)}
        if prior.get('effect') == case.truth:
            fits.update({'fitted_before': round(prior['strength'], 4),
                         'fitted_sd_before': round(prior['sd'], 4),
                         'at_edge_before': prior['at_range_edge']})
    return {**fits, 'verdict_before': was['verdict'], 'top_before': was['top'],
            'top_p_before': was['top_p'], 'correct_before': was['correct'],
            'brier_before': was['brier'], 'confident_wrong_before': was['confident_wrong'],
            'extra_simulations': adaptive['extra_simulations'], 'stop': adaptive['stop'],
            'steps': [[(r['candidate'], round(r['strength'], 4), r['why']) for r in s['runs']]
                      for s in adaptive['steps']]}


def budget_figures(rows: list[dict[str, Any]], budget: int) -> dict[str, Any]:
    """The budget's figures: simulations spent, open answers turned right, right answers lost,
    and the scores before (on the library alone)."""
    def settled(r: dict[str, Any]) -> bool:
        return bool(r['top1'] and r['verdict'] != 'inconclusive' and r['correct'])

    had = [r for r in rows if 'verdict_before' in r]
    return {
        'budget': budget,
        'extra_simulations': sum(r['extra_simulations'] for r in had),
        'resolved': sum(r['verdict_before'] == 'inconclusive' and settled(r) for r in had),
        'inconclusive_before': sum(r['verdict_before'] == 'inconclusive' for r in had),
        'correct_before': sum(r['correct_before'] for r in had),
        'lost': sum(r['correct_before'] and not r['correct'] for r in had),
        'false_confident_before': sum(r['confident_wrong_before'] for r in had),
        'brier_before': round(float(np.mean([r['brier_before'] for r in had])), 4)
        if had else None,
        'reliability_before': reliability([{**r, 'top': r['top_before'],
                                            'top_p': r['top_p_before']} for r in had])}


def reliability(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Top probability in bins against how often the top candidate was the truth."""
    out = []
    for lo, hi in ((0.0, 0.5), (0.5, 0.8), (0.8, 1.01)):
        sel = [r for r in rows if lo <= r['top_p'] < hi]
        if sel:
            out.append({'p': f'{lo:.1f}-{min(hi, 1.0):.1f}', 'n': len(sel),
                        'mean_p': round(float(np.mean([r['top_p'] for r in sel])), 3),
                        'hit_rate': round(float(np.mean([r['top'] == (r['truth'] or 'baseline')
                                                         for r in sel])), 3)})
    return out


def tree_cpu_s() -> float:
    """User + system CPU seconds of this process and of its ended children (the Dask workers
    once their cluster is closed) [s]."""
    own = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def bench_parser() -> argparse.ArgumentParser:
    """The options this bench shares with bench/recalibrate.py (scene, cache root, library)."""
    p = argparse.ArgumentParser()
    p.add_argument('--scene', default='reduced_1ms')
    p.add_argument('--root', type=Path, default=Path.home() / '.cache/dempath/bench-diagnose')
    p.add_argument('--seeds', default='1001,1002,1003')
    p.add_argument('--strengths', type=int, default=2)
    p.add_argument('--candidates', default=','.join(LIBRARY_CANDIDATES),
                   help='library candidates (comma-separated effect names)')
    p.add_argument('--serial', action='store_true')
    p.add_argument('--no-shared-settle', action='store_true',
                   help='every library run re-settles its own bed (the design before issue 30)')
    p.add_argument('--rest-tolerance-m', type=float, default=REST_TOLERANCE_M,
                   help='library runs end once their bed is at rest to this bound [m] '
                        '(dempath_sim.runs.rest); 0: followed to the end')
    p.add_argument('--library', type=Path,
                   help='a packed library file (e.g. the shipped reduced_1ms one) instead of '
                        'building the library under --root')
    return p


def library_args(args: argparse.Namespace) -> list[str]:
    """The library options of a diagnosis: the packed file, or the folder under --root (its
    growing copy with ``--budget``)."""
    if args.library is not None:
        return ['--library', str(args.library)]
    return ['--library-root', str(getattr(args, 'root_library', args.root / 'library'))]


def main() -> None:
    """Run the bench and print one JSON line last."""
    p = bench_parser()
    p.add_argument('--own-pour', action='store_true',
                   help="case beds poured with the case's own physics (default: the scene "
                        "file's physics on the case's seed, re-settled with the case's)")
    p.add_argument('--library-only', action='store_true',
                   help='build (or resume) the library, print its figures and stop')
    p.add_argument('--budget', type=int, default=0,
                   help='simulations beyond the library per diagnosis (issue 32); the runs go '
                        'into a copy of the library (ROOT/library-budgetN), which grows from '
                        "case to case as a user's would")
    args = p.parse_args()
    scene = load_scene(args.scene)
    duration = covering_duration(pass_travel_s(scene, {}), 0.0)
    spec = LibrarySpec(seeds=tuple(int(s) for s in args.seeds.split(',')), duration_s=duration,
                       n_strengths=args.strengths,
                       candidates=tuple(c for c in args.candidates.split(',') if c),
                       shared_settle=not args.no_shared_settle,
                       rest_tolerance_m=args.rest_tolerance_m)
    lib_root, packings = args.root / 'library', args.root / 'packings'
    timing = args.root / 'timing.json'
    spent = json.loads(timing.read_text()) if timing.is_file() else {'library_s': 0.0}
    spent.setdefault('library_cpu_s', 0.0)
    t0, cpu0 = time.monotonic(), tree_cpu_s()
    state, _done, total = library_state(scene, spec, lib_root)
    if args.library is not None:  # packed: built elsewhere, its build time is not this bench's
        state = 'ready'
    if state != 'ready':
        if args.serial:
            build_library(scene, spec, lib_root, serial_executor, packings)
        else:
            from dempath_diagnose.library.sweep import DaskSweep

            with DaskSweep() as sweep:
                build_library(scene, spec, lib_root, sweep.run, packings)
        spent['library_s'] += time.monotonic() - t0
        spent['library_cpu_s'] += tree_cpu_s() - cpu0
        args.root.mkdir(parents=True, exist_ok=True)
        timing.write_text(json.dumps(spent))
    if args.library_only:
        print(json.dumps({'scene': scene.name, 'simulations': total,
                          'library_s': round(spent['library_s'], 1),
                          'library_cpu_s': round(spent['library_cpu_s'], 1),
                          'shared_settle': spec.shared_settle,
                          'rest_tolerance_m': spec.rest_tolerance_m,
                          'load': [round(x, 2) for x in os.getloadavg()],
                          'library': str(lib_root)}))
        return
    if args.budget > 0 and args.library is None:
        import shutil

        grown = args.root / f'library-budget{args.budget}'
        if not grown.is_dir():
            shutil.copytree(lib_root, grown)
        args.root_library = grown
    rows = []
    for case in cases_for(scene.name):
        folder = args.root / 'cases' / case.name
        markers, force = make_case(scene, case, folder, until_s=duration,
                                   cache_dir=packings, own_pour=args.own_pour)
        for with_force in (True, False):
            out = folder / (('diag_force' if with_force else 'diag_markers')
                            + (f'_budget{args.budget}' if args.budget else ''))
            argv = ['--measured', str(markers), '--scene', args.scene, '--out', str(out),
                    *library_args(args), '--packing-cache', str(packings),
                    '--seeds', args.seeds, '--strengths', str(args.strengths),
                    '--candidates', args.candidates, '--serial',
                    '--budget', str(args.budget)]
            if with_force:
                argv += ['--force', str(force)]
            if diagnose_main(argv) != 0:
                continue
            data = json.loads((out / 'diagnosis.json').read_text())
            total = data['simulations'] if args.library is not None else total
            rows.append({**score(case, data), 'force': with_force, **adaptive_row(case, data)})
            print(json.dumps(rows[-1]))
    named = [r for r in rows if r['verdict'] in NAMED]
    figures = {
        'scene': scene.name, 'cases': len(rows),
        'top1_correct': sum(r['top1'] for r in rows),
        'correct': sum(r['correct'] for r in rows),
        'false_confident': sum(r['confident_wrong'] for r in rows),
        'inconclusive': sum(r['verdict'] == 'inconclusive' for r in rows),
        'named': len(named), 'named_right': sum(r['named'] == r['truth'] for r in named),
        'simulations': total, 'library_s': round(spent['library_s'], 1),
        'case_s': round(statistics.median(r['wall_s'] for r in rows), 2) if rows else None,
        'brier': round(float(np.mean([r['brier'] for r in rows])), 4) if rows else None,
        'reliability': reliability(rows)}
    if args.budget:
        figures.update(budget_figures(rows, args.budget))
    held = [r for r in rows if r['case'] in HELD_OUT]
    if held:  # reported apart: never used to choose the separation step's constants
        figures['held_out'] = {
            'cases': len(held), 'correct': sum(r['correct'] for r in held),
            'false_confident': sum(r['confident_wrong'] for r in held),
            'brier': round(float(np.mean([r['brier'] for r in held])), 4),
            **({'correct_before': sum(r.get('correct_before', False) for r in held),
                'brier_before': round(float(np.mean([r.get('brier_before', r['brier'])
                                                     for r in held])), 4)}
               if args.budget else {})}
    print(json.dumps(figures))


if __name__ == '__main__':
    main()
