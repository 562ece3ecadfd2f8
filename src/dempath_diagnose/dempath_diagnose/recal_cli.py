"""``dempath recalibrate``: switch on the diagnosed effect, fit its strength, watch the error fall.

``dempath recalibrate --measured M --scene S [--force F] [--diagnosis DIR/diagnosis.json |
--effect NAME[=START] ...] --out DIR [--budget N] [--scheduler ADDR]`` plus every option of
``dempath diagnose`` (the library and the allowance). Bad input: one ``error: <input>:
<problem>`` line and exit code 1; whatever was computed is written first.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from dempath.errors import DempathError
from dempath_diagnose.cli import _parser as diagnose_parser
from dempath_diagnose.cli import diagnosis_of
from dempath_diagnose.errors import DiagnosisError
from dempath_diagnose.recalibrate import (
    Recalibration,
    Step,
    check_strength,
    recalibrate,
    unchanged,
)


def _parser() -> argparse.ArgumentParser:
    p = diagnose_parser()
    p.prog = 'dempath recalibrate'
    p.description = __doc__.split('\n')[0]
    p.add_argument('--diagnosis', type=Path, help='diagnosis.json of an earlier diagnosis')
    p.add_argument('--effect', action='append', default=[],
                   help='NAME or NAME=START: candidate(s) to fit (tried in turn)')
    p.add_argument('--budget', type=int, default=12, help='at most this many simulations')
    p.add_argument('--seeds-per-eval', type=int, default=2,
                   help='library packing seeds per real evaluation (paired with the baseline)')
    p.add_argument('--also', action='append', default=[],
                   help='refit this existing parameter too (not yet supported)')
    return p


def _targets(args: argparse.Namespace, verdict: str, ranking: list[str],
             remaining: list[str]) -> list[tuple[str, float | None]]:
    """The candidates to fit, with optional start values."""
    if args.effect:
        out: list[tuple[str, float | None]] = []
        for text in args.effect:
            name, _, value = text.partition('=')
            try:
                out.append((name, float(value) if value else None))
            except ValueError as err:
                raise DiagnosisError(f'--effect {text!r}: START must be a number') from err
        return out
    if args.diagnosis is not None:
        try:
            data = json.loads(args.diagnosis.read_text())
            verdict, ranking = data['verdict'], [r['effect'] for r in data['ranking']]
            remaining = data.get('remaining', [])
        except (OSError, ValueError, KeyError) as err:
            msg = f'{args.diagnosis}: not a readable diagnosis.json ({err})'
            raise DiagnosisError(msg) from err
    if verdict == 'inconclusive':
        names = ', '.join(remaining or ranking[:3])
        raise DiagnosisError(f'diagnosis: inconclusive ({names} remain); choose with --effect '
                             'NAME (repeat it to try several in turn)')
    if verdict == 'nothing_significant':
        return []
    return [(ranking[0], None)]


def _executor(args: argparse.Namespace, stack: Any) -> Callable[..., None]:
    if args.serial:
        from dempath_diagnose.library import serial_executor

        return serial_executor
    from dempath_diagnose.sweep import DaskSweep

    return stack.enter_context(DaskSweep(args.scheduler, args.workers)).run  # type: ignore[no-any-return]


def _progress(step: Step, eta_s: float) -> None:
    print(f'iteration {step.iteration}: strength {step.strength:.4g}, error d^2 {step.error:.1f} '
          f'(emulated {step.emulated:.1f}), {step.simulations} simulations, '
          f'{step.elapsed_s:.0f} s, ETA <= {eta_s:.0f} s {step.note}', file=sys.stderr)


def run(args: argparse.Namespace) -> dict[str, Any]:
    """The whole command; returns recalibration.json's content."""
    from contextlib import ExitStack

    from dempath_diagnose.objective import Objective
    from dempath_diagnose.recal_outputs import write_all
    from dempath_diagnose.recal_runs import RealEvaluator
    from dempath_diagnose.report import write_outputs
    from dempath_diagnose.simulate import tool_geometry

    if args.budget <= 0:
        raise DiagnosisError(f'--budget {args.budget}: must be a positive number of simulations')
    if args.also:
        raise DiagnosisError(f'--also {args.also[0]}: refitting existing parameters beside the '
                             'effect is not supported yet')
    scene, spec, library, allowance, d = diagnosis_of(args)
    write_outputs(d, args.out, {'scene': scene.name, 'library': str(library.folder),
                                'allowance': vars(allowance)})
    dec = d.decision
    targets = _targets(args, dec.verdict, [f.name for f in dec.ranking], dec.remaining)
    objective = Objective(d.emulator, d.measured, d.observed, d.cov)
    emus = {c.candidate.name: c for c in d.emulator.candidates}
    _, _, cube = tool_geometry(scene)
    results: list[Recalibration] = []
    with ExitStack() as stack:
        executor = _executor(args, stack)
        for name, start in targets or [(dec.ranking[0].name, None)]:
            if name not in emus:
                raise DiagnosisError(f'--effect {name}: not a candidate of the signature library '
                                     f'(known: {", ".join(emus)})')
            if start is not None:
                check_strength(emus[name], start)
            evaluate = RealEvaluator(scene, library, spec, d.emulator, d.layout, cube,
                                     emus[name], args.out, executor, args.seeds_per_eval,
                                     args.packing_cache)
            budget = args.budget if targets else 0
            results.append(_fit(objective, emus[name], evaluate, budget, args, start))
            if results[-1].stop in ('interrupted', 'scheduler_lost'):
                break
    best = min(results, key=lambda r: r.after)
    tried = {r.effect: {'error_after': r.after, 'reduction': r.reduction} for r in results}
    return write_all(best, scene, args.out, {'tried': tried})


def _fit(objective: Any, cand: Any, evaluate: Any, budget: int, args: argparse.Namespace,
         start: float | None) -> Recalibration:
    if budget == 0:  # nothing significant: the control path, no simulation
        return unchanged(objective, cand)
    return recalibrate(objective, cand, evaluate, budget, args.seeds_per_eval, _progress, start)


def recalibrate_main(argv: Sequence[str] | None = None) -> int:
    """``dempath recalibrate``; 0, or 1 after one ``error: <input>: <problem>`` line."""
    args = _parser().parse_args(argv)
    try:
        data = run(args)
    except (DempathError, ValueError) as err:
        print(f'error: {err}', file=sys.stderr)
        return 1
    print(f'{data["effect"]}: {data["stop_reason"]}; error d^2 {data["error_before"]:.1f} -> '
          f'{data["error_after"]:.1f} (floor {data["floor"]["k"]})')
    return 0
