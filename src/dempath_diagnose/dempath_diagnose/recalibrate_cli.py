"""``dempath recalibrate``: switch on the diagnosed effect, fit its strength, watch the error fall.

``dempath recalibrate --measured M --scene S [--force F] [--diagnosis DIR/diagnosis.json |
--effect NAME[=START] ...] [--also PARAM ...] --out DIR [--budget N] [--scheduler ADDR]
[--publish-progress]`` plus every option of ``dempath diagnose`` (the library and the
allowance). Bad input: one ``error: <input>: <problem>`` line and exit code 1; whatever was
computed is written first (a lost scheduler or Ctrl-C still write the best scene so far).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from contextlib import ExitStack
from pathlib import Path
from typing import Any

from dempath.errors import DempathError
from dempath_diagnose.cli import _parser as diagnose_parser
from dempath_diagnose.cli import diagnosis_of
from dempath_diagnose.errors import DiagnosisError
from dempath_diagnose.library.store import serial_executor
from dempath_diagnose.recalibration.loop import (
    Recalibration,
    check_strength,
    recalibrate,
    unchanged,
)
from dempath_diagnose.recalibration.progress import Callback, fan_out, printer
from dempath_diagnose.recalibration.targets import (
    also_candidates,
    budgets,
    check_options,
    named,
    targets,
)


def _parser() -> argparse.ArgumentParser:
    p = diagnose_parser()
    p.prog = 'dempath recalibrate'
    p.description = __doc__.split('\n')[0]
    p.add_argument('--diagnosis', type=Path, help='diagnosis.json of an earlier diagnosis')
    p.add_argument('--effect', action='append', default=[],
                   help='NAME or NAME=START: candidate(s) to fit (tried in turn)')
    p.add_argument('--also', action='append', default=[],
                   help='refit this existing parameter beside the effect (CMA-ES; repeatable)')
    p.add_argument('--budget', type=int, default=12, help='at most this many simulations')
    p.add_argument('--seeds-per-eval', type=int, default=2,
                   help='library packing seeds per real evaluation (paired with the baseline)')
    p.add_argument('--publish-progress', action='store_true',
                   help='publish dempath_msgs/RecalibrationProgress on /diagnosis/recalibration')
    return p


def _executor(args: argparse.Namespace, stack: ExitStack) -> Any:
    """Serial, or a Dask executor that tells a lost scheduler from a failed run."""
    if args.serial:
        return serial_executor
    import logging

    from dempath_diagnose.library.sweep import DaskSweep
    from dempath_diagnose.recalibration.evaluations import dask_executor

    # A lost scheduler is reported in one line of ours; the client's own reconnect traceback
    # would bury it (restored when the command ends).
    client_log = logging.getLogger('distributed.client')
    stack.callback(client_log.setLevel, client_log.level)
    client_log.setLevel(logging.CRITICAL)
    return dask_executor(stack.enter_context(DaskSweep(args.scheduler, args.workers)).client)


def _callback(args: argparse.Namespace, stack: ExitStack) -> Callback:
    callbacks = [printer()]
    if args.publish_progress:
        from dempath_diagnose.nodes.progress_publisher import progress_publisher

        callbacks.append(stack.enter_context(progress_publisher(args.out.name)))
    return fan_out(callbacks)


def run(args: argparse.Namespace) -> dict[str, Any]:
    """The whole command; returns recalibration.json's content."""
    from dempath_diagnose.library.simulator import tool_geometry
    from dempath_diagnose.recalibration.evaluations import RealEvaluator
    from dempath_diagnose.recalibration.objective import Objective
    from dempath_diagnose.report.diagnosis_outputs import write_outputs

    if args.budget <= 0:
        raise DiagnosisError(f'--budget {args.budget}: must be a positive number of simulations')
    if args.seeds_per_eval <= 0:
        raise DiagnosisError(f'--seeds-per-eval {args.seeds_per_eval}: must be positive')
    check_options(args)  # before the diagnosis is computed or written
    scene, spec, library, allowance, d = diagnosis_of(args)
    write_outputs(d, args.out, {'scene': scene.name, 'library': str(library.folder),
                                'allowance': vars(allowance)})
    emus = {c.candidate.name: c for c in d.emulator.candidates}
    todo = targets(args, d.decision, list(emus))
    also = also_candidates(args.also, emus, [name for name, _ in todo])
    for name, start in todo:
        if start is not None:
            check_strength(emus[name], start)
    objective = Objective(d.emulator, d.measured, d.observed, d.cov)
    _, _, cube = tool_geometry(scene)
    results: list[tuple[Recalibration, Any]] = []
    is_named = named(args, d.decision)
    with ExitStack() as stack:
        executor = _executor(args, stack) if todo else serial_executor
        progress = _callback(args, stack)
        for (name, start), budget in zip(todo, budgets(args.budget, args.seeds_per_eval,
                                                       len(todo)), strict=False):
            cands = [emus[name], *also]
            evaluate = RealEvaluator(scene, library, spec, d.emulator, d.layout, cube, cands,
                                     args.out, executor, args.seeds_per_eval,
                                     args.packing_cache,
                                     None if args.scheduler and not args.serial else 'same')
            if len(todo) > 1:
                print(f'inconclusive: trying {name} ({budget} simulations)', file=sys.stderr)
            results.append((recalibrate(objective, cands, evaluate, budget,
                                        args.seeds_per_eval, progress, start,
                                        named=is_named), evaluate))
            if results[-1][0].stop in ('interrupted', 'scheduler_lost'):
                break
        if not todo:  # nothing significant: the control path, no simulation
            top = emus[d.decision.ranking[0].name]
            results.append((unchanged(objective, [top]), None))
    return _write(results, scene, library, d, cube, args)


def _write(results: list[tuple[Recalibration, Any]], scene: Any, library: Any, d: Any,
           cube: tuple[float, float, float], args: argparse.Namespace) -> dict[str, Any]:
    """Write the best result (the scene first), its paper metrics and figures."""
    from dempath_diagnose.report.recalibration_outputs import write_all, write_scene_of

    best, evaluate = min(results, key=lambda re: re[0].after)
    write_scene_of(best, scene, args.out)
    tried: dict[str, dict[str, Any]] = {
        r.effect: {'error_after': r.after, 'reduction': r.reduction, 'stop': r.stop,
                   'simulations': r.steps[-1].simulations} for r, _ in results}
    extra: dict[str, Any] = {'tried': tried}
    if len(results) > 1:
        down = [k for k, v in tried.items() if v['reduction'] > 0]
        extra['brings_error_down'] = min(down, key=lambda k: tried[k]['error_after']) \
            if down else ''
    figures: tuple[str, ...] = ()
    if evaluate is not None:
        from dempath_diagnose.cli import _origin
        from dempath_diagnose.decision.measure import load_tracks
        from dempath_diagnose.report.recalibration_paper import paper_and_trajectories

        meas = load_tracks(args.measured, _origin(args.origin))
        paper, figures = paper_and_trajectories(best, evaluate, library, d, cube, meas,
                                                args.noise, args.out)
        extra['paper'] = paper
    return write_all(best, scene, args.out, extra, figures)


def recalibrate_main(argv: Sequence[str] | None = None) -> int:
    """``dempath recalibrate``: fit the missing effect's strength against the measurement.

    Returns 0, or 1 after one ``error: <input>: <problem>`` line.
    A lost scheduler gives its error line after the outputs (best scene so far) are written.
    """
    args = _parser().parse_args(argv)
    try:
        data = run(args)
    except (DempathError, ValueError) as err:
        print(f'error: {err}', file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f'error: interrupted (Ctrl-C) before the fit started; {args.out} holds what was '
              'written', file=sys.stderr)
        return 130
    paper = data.get('paper')
    nrmse = (f'; mean nRMSE {paper["before"]["mean_nrmse_pct"]:.2f} -> '
             f'{paper["after"]["mean_nrmse_pct"]:.2f} % (floor '
             f'{paper["floor"]["mean_nrmse_pct"]:.2f} %)') if paper else ''
    print(f'{data["effect"]}: {data["stop_reason"]}; error d^2 {data["error_before"]:.1f} -> '
          f'{data["error_after"]:.1f} (floor {data["floor"]["k"]}){nrmse}')
    head = (paper or {}).get('headline', {})
    if head.get('before', {}).get('value_mm') is not None and \
            head.get('after', {}).get('value_mm') is not None:
        from dempath_diagnose.headline.stage import headline_sentence

        print(headline_sentence(head['before'], 'before'))
        print(headline_sentence(head['after'], 'after'))
    if data['stop'] == 'scheduler_lost':
        print(f'error: {data["note"]}', file=sys.stderr)
        return 1
    return 130 if data['stop'] == 'interrupted' else 0
