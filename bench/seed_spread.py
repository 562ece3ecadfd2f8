"""Is the diagnosis calibrated with the seed spread and grain scatter of each strength?

The emulator's covariance used to be pooled over every model's runs: one seed covariance and one
one-particle sampling covariance for the baseline and every candidate at every strength. On the
tiny scene a cohesive bed (1e5 J/m^3) scatters eight times more than the pool and the baseline
less than half, so strong cohesion was ruled out at its own fit (issue 32). Now each strength
keeps its own sampling covariance (``emulator.OWN_SAMPLING``) and a level of the seed covariance
(:func:`dempath_diagnose.decision.emulator.spread_levels`), shrunk towards the pool's with the
pool worth ``prior_dof`` degrees of freedom.

This bench diagnoses every hidden-effect case of ``bench/diagnose.py`` (its cached library and
case passes under ``--root``) and strong cohesion on the two other case beds (2 simulations,
cached), with and without the force, on the library alone, under each variant: pooled sampling
with the pooled seed spread (before), and own sampling with several ``prior_dof`` (``inf``: the
pooled seed spread). Each answer is scored as that bench scores it: right answers, confident
wrong ones, the Brier score and the reliability table of the top probability.

The cases are split by bed: those on case seeds 7 and 9 are the *tuned* ones (the variant is
chosen on them: the lowest Brier score with no confident wrong answer), those on seed 8 are held
out. The last line is one JSON object.

Usage: ``.venv/bin/python bench/diagnose.py --scene tiny --serial --root DIR`` first (library
and cases), then ``.venv/bin/python bench/seed_spread.py --root DIR``.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

from dempath_diagnose.decision import emulator
from dempath_diagnose.decision.diagnosis import CaseGeometry, diagnose
from dempath_diagnose.entry.diagnosis import measurement_of
from dempath_diagnose.entry.requests import DiagnoseRequest
from dempath_diagnose.library.cases import HiddenCase, make_case
from dempath_diagnose.library.simulator import load_scene, pass_travel_s, tool_geometry
from dempath_diagnose.library.store import Library, covering_duration
from dempath_diagnose.report.diagnosis_outputs import to_json

sys.path.insert(0, str(Path(__file__).parent))
from diagnose import CASE_SEEDS, cases_for, reliability, score  # bench/diagnose.py

STRONG = {'cohesion.energy_density_j_m3': 1e5}

TUNED_SEEDS = (CASE_SEEDS[0], CASE_SEEDS[2])
# (own grain scatter per strength, pooled seed spread's weight [dof]); (False, inf): before
VARIANTS = ((False, float('inf')), (False, 2.0), (True, float('inf')), (True, 8.0),
            (True, 2.0), (True, 0.5), (True, 0.0))


def summary(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Right answers, confident wrong ones, Brier score and reliability of some rows."""
    return {'answers': len(rows), 'correct': sum(r['correct'] for r in rows),
            'top1': sum(r['top1'] for r in rows),
            'confident_wrong': sum(r['confident_wrong'] for r in rows),
            'inconclusive': sum(r['verdict'] == 'inconclusive' for r in rows),
            'brier': round(float(np.mean([r['brier'] for r in rows])), 4) if rows else None,
            'reliability': reliability(rows)}


def main() -> None:
    """Diagnose every cached case under each prior weight; print one JSON line last."""
    p = argparse.ArgumentParser()
    p.add_argument('--root', type=Path, required=True, help="bench/diagnose.py's --root")
    p.add_argument('--scene', default='tiny')
    args = p.parse_args()
    (folder,) = sorted((args.root / 'library').iterdir())
    library = Library.load(folder)
    scene = load_scene(args.scene)
    geometry = CaseGeometry(*tool_geometry(scene))
    cases = [(c, args.root / 'cases' / c.name) for c in cases_for(args.scene)
             if (args.root / 'cases' / c.name / 'markers.csv').is_file()]
    duration = covering_duration(pass_travel_s(scene, {}), 0.0)
    for seed in (CASE_SEEDS[0], CASE_SEEDS[2]):
        case = HiddenCase(f'cohesion_strong_s{seed}', STRONG, 'cohesion', ('effect_missing',),
                          seed=seed)
        where = args.root / 'extra_cases' / case.name
        make_case(scene, case, where, until_s=duration, cache_dir=args.root / 'packings')
        cases.append((case, where))
    rows: dict[str, list[dict[str, Any]]] = {}
    for own, prior in VARIANTS:
        emulator.OWN_SAMPLING, emulator.SPREAD_PRIOR_DOF = own, prior
        variant = f'{"own" if own else "pooled"}_sampling,prior_dof={prior:g}'
        rows[variant] = []
        for case, where in cases:
            for force in (True, False):
                request = DiagnoseRequest(
                    measured=where / 'markers.csv', scene=args.scene, out=where / 'unused',
                    force=where / 'force.csv' if force else None)
                result = diagnose(measurement_of(request, scene), library, geometry,
                                  force_source=str(request.force))
                data = to_json(result)
                top = result.decision.ranking[0]
                row = {**score(case, data), 'force': force, 'seed': case.seed,
                       'variant': variant, 'implausibility': round(top.implausibility, 2),
                       'fitted': top.strength}
                rows[variant].append(row)
                print(json.dumps(row), flush=True)
    figures = {}
    for variant, some in rows.items():
        tuned = [r for r in some if r['seed'] in TUNED_SEEDS]
        held = [r for r in some if r['seed'] not in TUNED_SEEDS]
        figures[variant] = {'tuned': summary(tuned), 'held_out': summary(held),
                            'all': summary(some)}
    safe = [v for v in rows if figures[v]['tuned']['confident_wrong'] == 0]
    chosen = min(safe, key=lambda v: figures[v]['tuned']['brier']) if safe else None
    print(json.dumps({'scene': args.scene, 'chosen': chosen, 'variants': figures}))


if __name__ == '__main__':
    main()
