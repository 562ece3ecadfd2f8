"""``run_recalibration(RecalibrationRequest) -> RecalibrationOutcome``: switch on the diagnosed
effect, fit its strength, and write what changed.

What ``dempath recalibrate`` does after parsing its options: the diagnosis (given, or computed
here and written beside the recalibration), the candidates to fit (asked for, or named by the
diagnosis), one fit per candidate within the simulation budget, then the best scene first and
its paper metrics and figures. Whatever was computed is written even when the scheduler is lost
or the fit is interrupted (the outcome's ``stop`` says so).
"""

from __future__ import annotations

import sys
from contextlib import ExitStack
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from dempath_diagnose.entry.diagnosis import DiagnosisOutcome, diagnosis_of
from dempath_diagnose.entry.requests import RecalibrationRequest
from dempath_diagnose.library.simulator import tool_geometry
from dempath_diagnose.library.store import serial_executor
from dempath_diagnose.recalibration.loop import (
    Recalibration,
    check_strength,
    recalibrate,
    unchanged,
)
from dempath_diagnose.recalibration.progress import Callback, printer
from dempath_diagnose.recalibration.targets import (
    also_candidates,
    budgets,
    check_options,
    named,
    targets,
)


@dataclass(frozen=True)
class RecalibrationOutcome:
    """A recalibration and where its outputs are.

    Attributes:
        request: What was asked.
        diagnosis: The diagnosis it built on.
        best: The fit with the lowest error after (of the candidates tried).
        data: recalibration.json's content.
        scene_file: The recalibrated scene written for ``best``.
    """

    request: RecalibrationRequest
    diagnosis: DiagnosisOutcome
    best: Recalibration
    data: dict[str, Any]
    scene_file: Path

    @property
    def stop(self) -> str:
        """Why the fit stopped (``floor``, ``budget``, ..., ``scheduler_lost``)."""
        return str(self.data['stop'])


def run_recalibration(request: RecalibrationRequest, diagnosis: DiagnosisOutcome | None = None,
                      progress: Callback | None = None) -> RecalibrationOutcome:
    """The whole recalibration; writes its outputs into ``request.out``.

    Args:
        request: What to fit and how.
        diagnosis: A diagnosis of the same measurement, scene and library already computed
            (the demo's); None: computed here from ``request.diagnose``.
        progress: Called with each iteration's progress (default: a line on stderr; the
            command adds the ROS publisher of ``--publish-progress`` to it).

    Raises:
        DempathError: Bad input (one line naming it) before anything is written.
        KeyboardInterrupt: Ctrl-C before the fit started.
    """
    from dempath_diagnose.recalibration.evaluations import RealEvaluator
    from dempath_diagnose.recalibration.objective import Objective
    from dempath_diagnose.report.diagnosis_outputs import write_outputs

    ask = request.diagnose
    check_options(request.effects, ask.candidates, request.diagnosis_file)  # before any work
    base = diagnosis if diagnosis is not None else diagnosis_of(ask)
    scene, spec, library, d = base.scene, base.spec, base.library, base.diagnosis
    write_outputs(d, request.out, {'scene': scene.name, 'library': str(library.folder),
                                   'allowance': vars(ask.allowance),
                                   'held_out': list(ask.held_out)})
    emus = {c.candidate.name: c for c in d.emulator.candidates}
    todo = targets(request.effects, request.diagnosis_file, d.decision, list(emus))
    also = also_candidates(request.also, emus, [name for name, _ in todo])
    for name, start in todo:
        if start is not None:
            check_strength(emus[name], start)
    objective = Objective(d.emulator, d.measured, d.observed, d.cov)
    _, _, cube = tool_geometry(scene)
    results: list[tuple[Recalibration, Any]] = []
    is_named = named(request.effects, request.diagnosis_file, d.decision)
    with ExitStack() as stack:
        executor = _executor(request, stack) if todo else serial_executor
        callback = progress or printer()
        for (name, start), budget in zip(todo, budgets(request.budget, request.seeds_per_eval,
                                                       len(todo)), strict=False):
            cands = [emus[name], *also]
            evaluate = RealEvaluator(scene, library, spec, d.emulator, d.layout, cube, cands,
                                     request.out, executor, request.seeds_per_eval,
                                     ask.packing_cache,
                                     None if ask.scheduler and not ask.serial else 'same')
            if len(todo) > 1:
                print(f'inconclusive: trying {name} ({budget} simulations)', file=sys.stderr)
            own = replace(objective, floor_band=d2_band(library, d, cands, cube, ask))
            results.append((recalibrate(own, cands, evaluate, budget,
                                        request.seeds_per_eval, callback, start,
                                        named=is_named), evaluate))
            if results[-1][0].stop in ('interrupted', 'scheduler_lost'):
                break
        if not todo:  # nothing significant: the control path, no simulation
            top = emus[d.decision.ranking[0].name]
            results.append((unchanged(objective, [top]), None))
    return _write(request, base, results, cube)


def d2_band(library: Any, d: Any, cands: list[Any], cube: tuple[float, float, float],
            ask: Any) -> Any:
    """The like-for-like d^2 band the loop stops on (:mod:`dempath_diagnose.headline.d2floor`):
    the model at the strengths (the baseline at the scene's own value, else the candidate
    fitted again) played as the measurement by each library seed with the diagnosis' markers,
    samples, layout and covariance; cached by strength. None (the nominal chi^2 mean) when more
    than one strength is fitted; a band that cannot be computed (the library lacks the
    candidate's runs) is None too."""
    from dempath_diagnose.headline.d2floor import D2Setup, d2_floor
    from dempath_diagnose.headline.samples import MarkerSamples

    if len(cands) != 1 or d.measurement is None:
        return None
    cand = cands[0].candidate
    setup = D2Setup(d.layout, cube, ask.allowance)
    samples = MarkerSamples.of(d.measurement)
    cache: dict[float, Any] = {}

    def band(x: tuple[float, ...]) -> Any:
        if x[0] not in cache:
            base = x[0] == cand.current
            try:
                cache[x[0]] = d2_floor(library, '' if base else cand.name, x[0], samples,
                                       setup, fitted=not base)
            except (KeyError, ValueError, LookupError):
                cache[x[0]] = None
        return cache[x[0]]

    return band


def _executor(request: RecalibrationRequest, stack: ExitStack) -> Any:
    """Serial, or a Dask executor that tells a lost scheduler from a failed run."""
    if request.diagnose.serial:
        return serial_executor
    import logging

    from dempath_diagnose.library.sweep import DaskSweep
    from dempath_diagnose.recalibration.evaluations import dask_executor

    # A lost scheduler is reported in one line of ours; the client's own reconnect traceback
    # would bury it (restored when the command ends).
    client_log = logging.getLogger('distributed.client')
    stack.callback(client_log.setLevel, client_log.level)
    client_log.setLevel(logging.CRITICAL)
    sweep = DaskSweep(request.diagnose.scheduler, request.diagnose.workers)
    return dask_executor(stack.enter_context(sweep).client)


def _write(request: RecalibrationRequest, base: DiagnosisOutcome,
           results: list[tuple[Recalibration, Any]],
           cube: tuple[float, float, float]) -> RecalibrationOutcome:
    """Write the best result (the scene first), its paper metrics and figures."""
    from dempath_diagnose.report.recalibration_outputs import write_all, write_scene_of

    scene, out = base.scene, request.out
    best, evaluate = min(results, key=lambda re: re[0].after)
    scene_file = write_scene_of(best, scene, out)
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
        from dempath_diagnose.decision.measure import load_tracks
        from dempath_diagnose.report.recalibration_paper import paper_and_trajectories

        ask = request.diagnose
        meas, held = load_tracks(ask.measured, ask.origin).split(ask.held_out)
        paper, figures = paper_and_trajectories(best, evaluate, base.library, base.diagnosis,
                                                cube, meas, ask.allowance.noise_m, out,
                                                held if ask.held_out else None)
        extra['paper'] = paper
    data = write_all(best, scene, out, extra, figures)
    return RecalibrationOutcome(request, base, best, data, scene_file)


def summary_lines(data: dict[str, Any]) -> list[str]:
    """What the recalibration changed, in a few lines: the stop, the error before and after
    beside the floor (and the paper's mean nRMSE), the headline error before and after."""
    paper = data.get('paper')
    after_floor = (f', after\'s own {paper["floor_after"]["mean_nrmse_pct"]:.2f} %'
                   if paper and paper.get('floor_after') else '')
    nrmse = (f'; mean nRMSE {paper["before"]["mean_nrmse_pct"]:.2f} -> '
             f'{paper["after"]["mean_nrmse_pct"]:.2f} % (floor before '
             f'{paper["floor"]["mean_nrmse_pct"]:.2f} %{after_floor})') if paper else ''
    lines = [f'{data["effect"]}: {data["stop_reason"]}; error d^2 {data["error_before"]:.1f} -> '
             f'{data["error_after"]:.1f} ({d2_floor_text(data)}){nrmse}']
    head = (paper or {}).get('headline', {})
    if head.get('before', {}).get('value_mm') is not None and \
            head.get('after', {}).get('value_mm') is not None:
        from dempath_diagnose.headline.stage import headline_sentence

        lines += [headline_sentence(head['before'], 'before'),
                  headline_sentence(head['after'], 'after')]
    held = (paper or {}).get('headline_held_out')
    if held:
        from dempath_diagnose.headline.stage import held_out_sentence

        lines += [line for line in [held_out_sentence(held)] if line]
    return lines


def d2_floor_text(data: dict[str, Any]) -> str:
    """What the loop judged d^2 by: the last like-for-like band, or the nominal chi^2 mean."""
    bands = data.get('floor_bands') or []
    if not bands:
        return f'stopped on the nominal chi^2 mean k = {data["floor"]["k"]}: no like-for-like ' \
            'band could be computed'
    b = bands[-1]
    return (f"like-for-like floor band {max(b['low'], 0.0):.1f}-{b['high']:.1f} of the model at "
            f"{', '.join(f'{v:.4g}' for v in b['strengths'])} ({b['seeds']} seeds played "
            'the measurement)')
