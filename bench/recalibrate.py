"""Recalibration of the hidden-effect cases (issue 14's proof), on top of bench/diagnose.py.

For each case of ``bench/diagnose.py`` where the truth is a strong effect or parameter, and for
the controls: ``dempath recalibrate`` on the case's measurement (with the force) against the
scene's signature library, at most ``--budget`` new simulations per case. Cached under
``--root`` (the same root as bench/diagnose.py: library, packings, cases); a case whose
recalibration.json exists is not redone, so an interrupted bench resumes. The last line is one
JSON object: cases, error_reduction (median fraction of the error above the floor removed over
the cases whose error was above the floor; cases_above_floor of them; changed_within_floor: the
others the recalibration still changed), simulations, wall_s, strength_within_uncertainty
(fitted strength within 2 reported sd of the hidden one), control_unchanged.

Usage: ``.venv/bin/python bench/recalibrate.py [--scene reduced_1ms] [--root DIR] [--serial]``
(``--scene tiny`` for a quick check; run bench/diagnose.py first or let this build the library).
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).parent))

from diagnose import bench_parser, cases_for, library_args  # bench/diagnose.py: the same cases

from dempath_diagnose.library.cases import HiddenCase, make_case
from dempath_diagnose.library.simulator import load_scene, pass_travel_s, scene_candidates
from dempath_diagnose.library.store import covering_duration
from dempath_diagnose.recalibrate_cli import recalibrate_main

STRONG = ('tool_speed_1.5', 'tool_speed_0.7', 'cohesion_strong', 'tool_friction_x2')
CONTROLS = ('control',)


def hidden_strength(scene: Any, case: HiddenCase) -> float:
    """The hidden value of the case's main parameter."""
    (cand,) = scene_candidates(scene, (case.truth,))
    return float(case.overrides[f'{cand.name}.{cand.parameter}'])


def run_case(args: argparse.Namespace, scene: Any, case: HiddenCase, duration: float,
             ) -> dict[str, Any] | None:
    """Recalibrate one case (cached); its row."""
    root = args.root
    folder = root / 'cases' / case.name
    markers, force = make_case(scene, case, folder, until_s=duration,
                               cache_dir=root / 'packings')
    out = folder / 'recal'
    t0 = time.monotonic()
    if not (out / 'recalibration.json').is_file():
        argv = ['--measured', str(markers), '--force', str(force), '--scene', args.scene,
                '--out', str(out), *library_args(args),
                '--packing-cache', str(root / 'packings'), '--seeds', args.seeds,
                '--strengths', str(args.strengths), '--budget', str(args.budget),
                '--seeds-per-eval', str(args.seeds_per_eval)]
        if args.candidates:
            argv += ['--candidates', args.candidates]
        if args.serial:
            argv.append('--serial')
        if recalibrate_main(argv) != 0:
            return None
        data = json.loads((out / 'recalibration.json').read_text())
        data['wall_s'] = time.monotonic() - t0
        (out / 'recalibration.json').write_text(json.dumps(data, indent=2))
    data = json.loads((out / 'recalibration.json').read_text())
    row = {'case': case.name, 'effect': data['effect'], 'stop': data['stop'],
           'changed': data['changed'], 'before': data['error_before'],
           'after': data['error_after'], 'reduction': data['error_reduction'],
           'simulations': data['simulations'], 'wall_s': data['wall_s'],
           'floor_k': data['floor']['k']}
    paper = data.get('paper')
    if paper:  # Table 7's mean nRMSE [%] before / after and the true model's over seeds
        row.update(nrmse_before=paper['before']['mean_nrmse_pct'],
                   nrmse_after=paper['after']['mean_nrmse_pct'],
                   nrmse_floor=paper['floor']['mean_nrmse_pct'])
    if case.truth:
        hidden = hidden_strength(scene, case)
        s = data['strength']
        row.update(hidden=hidden, fitted=s['value'], sd=s['uncertainty'],
                   within=bool(data['effect'] == case.truth
                               and abs(s['value'] - hidden) <= 2 * s['uncertainty']))
    return row


def main() -> None:
    """Run the cases and print one JSON line last."""
    p = bench_parser()
    p.add_argument('--budget', type=int, default=6)
    p.add_argument('--seeds-per-eval', type=int, default=2)
    p.add_argument('--cases', default=','.join(STRONG + CONTROLS))
    args = p.parse_args()
    scene = load_scene(args.scene)
    duration = covering_duration(pass_travel_s(scene, {}), 0.0)
    wanted = args.cases.split(',')
    rows = []
    for case in cases_for(scene.name):
        if case.name in wanted and (row := run_case(args, scene, case, duration)) is not None:
            rows.append(row)
            print(json.dumps(row))
    named = [r for r in rows if r['case'] not in CONTROLS]
    above = [r for r in named if r['before'] > r['floor_k']]  # an error above the floor to remove
    controls = [r for r in rows if r['case'] in CONTROLS]
    print(json.dumps({
        'scene': scene.name, 'cases': len(rows),
        'error_reduction': round(statistics.median(r['reduction'] for r in above), 3)
        if above else None,
        'cases_above_floor': len(above),
        'changed_within_floor': sum(r['changed'] for r in named if r not in above),
        'simulations': sum(r['simulations'] for r in rows),
        'wall_s': round(sum(r['wall_s'] for r in rows), 1),
        'strength_within_uncertainty': sum(r.get('within', False) for r in named),
        'strong_cases': len(named),
        'control_unchanged': all(not r['changed'] for r in controls),
        'mean_nrmse_before': _median(named, 'nrmse_before'),
        'mean_nrmse_after': _median(named, 'nrmse_after'),
        'mean_nrmse_floor': _median(named, 'nrmse_floor')}))


def _median(rows: list[dict[str, Any]], key: str) -> float | None:
    """Median of ``key`` over the rows that have it (None if none has)."""
    values = [r[key] for r in rows if key in r]
    return round(statistics.median(values), 2) if values else None


if __name__ == '__main__':
    main()
