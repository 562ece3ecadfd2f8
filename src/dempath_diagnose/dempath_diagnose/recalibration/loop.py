"""The recalibration loop: fit the named candidate, confirm with real runs, stop at the floor.

The candidate's strength (and, with ``--also``, existing parameters refitted beside it) is
searched on the diagnosis' emulator (:mod:`dempath_diagnose.recalibration.search`: a bounded scalar
search for one strength, CMA-ES for several), then confirmed by a real evaluation at the
proposed strengths. Each real evaluation runs on the library's packing seeds and is *paired*
with the library's baseline runs on the same seeds (:mod:`.evaluations`), so the
chaos of a few packings cancels and does not steer the fit. After each real evaluation the
emulator is corrected by the observed bias (real minus emulated statistics at those strengths,
Kennedy & O'Hagan's discrepancy in its simplest, constant form) and the search runs again.

Stops: at the floor (d^2 no longer above the like-for-like floor band of the model at the best
strengths so far, :mod:`objective`; the nominal mean of chi^2_k only where no band can be
computed), at the budget of simulations, when the error stops falling (an iteration removes
less than ``MIN_GAIN`` of the error above the nominal floor), on a lost scheduler or on Ctrl-C
(the best strengths so far are kept).
A candidate whose simulation fails (an unstable run) is scored as failed and the next proposal
moves half way back towards the scene's current values.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from scipy.stats import chi2

from dempath_diagnose.decision.emulator import CandidateEmulator
from dempath_diagnose.decision.verdict import fit_candidate
from dempath_diagnose.errors import DiagnosisError
from dempath_diagnose.recalibration.objective import Floor, Objective
from dempath_diagnose.recalibration.progress import Callback, Progress, State
from dempath_diagnose.recalibration.search import emulated_d2, laplace_sd, propose
from dempath_diagnose.records import F64

SIGNIFICANT_CHANGE = 0.95  # a fit of n strengths must lower d^2 by chi^2_n's quantile to count
MIN_GAIN = 0.05  # an iteration that removes less of the error above the floor ends the loop


class SweepLostError(DiagnosisError):
    """The simulations' scheduler went away mid-sweep (the loop stops; the best so far is kept)."""


Evaluate = Callable[[F64], F64]  # strengths (n,) -> (S, k) paired-corrected statistics per seed


@dataclass(frozen=True)
class Step:
    """One iteration: what was tried and what it gave.

    Attributes:
        iteration: 0 for the scene as it is, then 1, 2, ...
        strengths: The strengths tried (the scene's current values at iteration 0).
        error: d^2 of the real runs (inf for a failed candidate).
        emulated: d^2 the emulator predicted.
        simulations: Simulations used so far.
        elapsed_s: Wall time so far [s].
        note: '' or why the step failed.
    """

    iteration: int
    strengths: tuple[float, ...]
    error: float
    emulated: float
    simulations: int
    elapsed_s: float
    note: str = ''

    @property
    def strength(self) -> float:
        """The main candidate's strength."""
        return self.strengths[0]


@dataclass
class Param:
    """One fitted strength: ``name.parameter`` [unit], from ``current`` to ``value`` +- ``sd``."""

    name: str
    parameter: str
    unit: str
    current: float
    value: float
    sd: float = 0.0


@dataclass
class Recalibration:
    """The loop's result.

    Attributes:
        params: The fitted strengths, the candidate first, then the ``--also`` parameters.
        before, after: d^2 of the scene as it is and with the fitted strengths.
        floor: The floor of the observed statistics.
        steps: Every iteration.
        stop: ``floor``, ``budget``, ``stalled``, ``interrupted``, ``scheduler_lost`` or
            ``nothing_to_fit``.
        changed: Whether the scene changes.
        failures: Failed (unstable) candidates.
        note: Details of the stop.
        bias, bias_var: (k,) real minus emulated statistics at the best real evaluation, and
            the variance of that seed mean (None before any real evaluation): the emulator's
            error there, which the strengths' uncertainty carries.
        floor_bands: The like-for-like d^2 band the loop judged each iteration by (the model
            at that iteration's best strengths; iteration 0: the model as it is), JSON-ready;
            empty when the loop stopped on the nominal chi^2 mean.
    """

    params: list[Param]
    before: float
    after: float
    floor: Floor
    steps: list[Step] = field(default_factory=list)
    stop: str = ''
    changed: bool = False
    failures: int = 0
    note: str = ''
    bias: F64 | None = None
    bias_var: F64 | None = None
    floor_bands: list[dict[str, Any]] = field(default_factory=list)

    @property
    def effect(self) -> str:
        """The candidate fitted."""
        return self.params[0].name

    @property
    def strengths(self) -> tuple[float, ...]:
        """The fitted values."""
        return tuple(p.value for p in self.params)

    @property
    def reduction(self) -> float:
        """Fraction of the error above the floor removed (1: down to the floor)."""
        above = self.floor.above(self.before)
        if above == 0.0:
            return 0.0
        return float(np.clip((self.before - self.after) / above, -np.inf, 1.0))

    def progress(self, eta_s: float, state: State = State.RUNNING, detail: str = '',
                 ) -> Progress:
        """The progress record of the last step."""
        s = self.steps[-1]
        band = self.floor_bands[-1] if self.floor_bands else None  # the last band judged by
        return Progress(self.effect, s.iteration, s.error, self.after,
                        band['median'] if band else self.floor.k,
                        band['high'] if band else self.floor.significant,
                        tuple(f'{p.name}.{p.parameter}' for p in self.params), s.strengths,
                        s.simulations, eta_s, state, detail, band is not None)


def check_strength(cand: CandidateEmulator, value: float) -> None:
    """DiagnosisError when ``value`` lies outside the effect's physical range."""
    c = cand.candidate
    if not (np.isfinite(value) and c.low <= value <= c.high):
        msg = (f'{c.name}.{c.parameter} = {value:g} {c.unit}: outside the physical range '
               f'[{c.low:g}, {c.high:g}]')
        raise DiagnosisError(msg)


def unchanged(objective: Objective, cands: Sequence[CandidateEmulator]) -> Recalibration:
    """The scene as it is (iteration 0 only, stop ``nothing_to_fit``): the control's answer."""
    before = objective.baseline()
    params = [Param(c.candidate.name, c.candidate.parameter, c.candidate.unit,
                    c.candidate.current, c.candidate.current) for c in cands]
    out = Recalibration(params, before, before, objective.floor, stop='nothing_to_fit')
    out.steps.append(Step(0, tuple(p.current for p in params), before, before, 0, 0.0))
    return out


def recalibrate(objective: Objective, cands: CandidateEmulator | Sequence[CandidateEmulator],
                evaluate: Evaluate, budget: int, seeds_per_eval: int,
                progress: Callback | None = None,
                start: float | None = None, named: bool = False) -> Recalibration:
    """Fit the strengths of ``cands`` (the candidate first); see the module docstring.

    Args:
        objective: The diagnosis' likelihood and floor.
        cands: The candidate, or the candidate and the parameters refitted beside it.
        evaluate: Runs the real simulations at strengths (n,) -> (S, k) statistics.
        budget: At most this many simulations.
        seeds_per_eval: Simulations per real evaluation.
        progress: Called with a :class:`Progress` after each iteration and at the end.
        start: The candidate's first strength (the others start at the scene's values).
        named: The diagnosis named this candidate (effect_missing / parameter_off): fit it even
            when the total d^2 is within the floor. One strongly deviating statistic (a draft
            force 5 seed spreads off) can hide in the mean of chi^2_k while the diagnosis'
            model comparison sees it; the change must still pass the chi^2_n test below.

    Raises:
        DiagnosisError: A budget below one evaluation.
    """
    cands = [cands] if isinstance(cands, CandidateEmulator) else list(cands)
    if budget < seeds_per_eval or budget <= 0:
        raise DiagnosisError(f'--budget {budget}: at least {seeds_per_eval} simulations '
                             '(one evaluation over the packing seeds) are needed')
    t0 = time.monotonic()
    out = unchanged(objective, cands)
    if progress is not None:
        progress(out.progress(0.0))
    if not _above_floor(objective, out, out.before, out.steps[0].strengths) and not named:
        _finish(out, progress)
        return out
    out.stop = ''
    _loop(out, objective, cands, evaluate, (budget, seeds_per_eval), progress, t0, start)
    out.changed = out.before - out.after > float(chi2.ppf(SIGNIFICANT_CHANGE, len(cands)))
    if out.changed:
        _uncertainty(out, objective, cands)
    else:
        for p in out.params:
            p.value, p.sd = p.current, 0.0
    _finish(out, progress)
    return out


def _uncertainty(out: Recalibration, objective: Objective,
                 cands: Sequence[CandidateEmulator]) -> None:
    """The fitted strengths' sd: the posterior sd for one, Laplace for several, both on the
    emulator corrected by the real runs' bias, with the bias' own sampling variance added.

    The value reported is the best strength really run, which the search may have stopped at
    before reaching the corrected posterior's mean (the floor was reached): for one strength the
    sd also carries that offset, sqrt(sd_post^2 + (value - mean_post)^2). Without the correction
    the sd is the emulator's alone, which knows nothing of the emulator's error: on the
    full-size bench a tool speed fitted from the force landed ~3 sd from the truth.
    """
    objective = _bias_corrected(objective, out)
    if len(cands) == 1:
        fit = fit_candidate(objective.emulator, cands[0], objective.y, objective.observed,
                            objective.cov)
        offset = out.params[0].value - fit.strength if out.bias is not None else 0.0
        out.params[0].sd = float(np.hypot(fit.strength_sd, offset))
        return
    sds = laplace_sd(objective, cands, np.array(out.strengths))
    for p, s in zip(out.params, sds, strict=True):
        p.sd = float(s)


def _bias_corrected(objective: Objective, out: Recalibration) -> Objective:
    """The objective whose emulator is shifted by the observed bias (constant in the strength,
    as the loop's own correction), its covariance widened by the bias' sampling variance."""
    if out.bias is None or out.bias_var is None or not np.all(np.isfinite(out.bias)):
        return objective
    obs = objective.observed
    return replace(objective, y=np.asarray(objective.y - out.bias[obs], np.float64),
                   cov=np.asarray(objective.cov + np.diag(out.bias_var), np.float64))


def _finish(out: Recalibration, progress: Callback | None) -> None:
    if progress is None:
        return
    state = {'interrupted': State.INTERRUPTED, 'scheduler_lost': State.FAILED}.get(
        out.stop, State.FINISHED)
    progress(out.progress(0.0, state, out.stop))


def _next(objective: Objective, cands: Sequence[CandidateEmulator], out: Recalibration,
          bias: F64 | None, x: F64, last_fail: bool, start: float | None) -> F64:
    """The strengths of the next real evaluation."""
    current = np.array([p.current for p in out.params])
    if start is not None and len(out.steps) == 1:
        return np.asarray(np.concatenate([[start], current[1:]]), np.float64)
    if last_fail:
        return np.asarray((x + current) / 2, np.float64)
    best = np.array(out.steps[0].strengths) if len(out.steps) == 1 else x
    return propose(objective, cands, bias, best)


def _loop(out: Recalibration, objective: Objective, cands: Sequence[CandidateEmulator],
          evaluate: Evaluate, sizes: tuple[int, int], progress: Callback | None,
          t0: float, start: float | None) -> None:
    """Propose, evaluate, correct until a stop; fills ``out`` in place."""
    budget, per = sizes
    bias: F64 | None = None
    used, x, last_fail = 0, np.array(out.steps[0].strengths), False
    try:
        while True:
            if used + per > budget:
                out.stop = 'budget'
                return
            x = _next(objective, cands, out, bias, x, last_fail, start)
            emulated = emulated_d2(objective, cands, x)
            note, last_fail = '', False
            try:
                runs = evaluate(x)
                error = objective.real(runs)
            except SweepLostError as err:
                out.stop, out.note = 'scheduler_lost', str(err)
                return
            except DiagnosisError as err:
                error, note, last_fail = math.inf, f'failed: {err}', True
                out.failures += 1
            used += per
            step = Step(len(out.steps), tuple(float(v) for v in x), error, emulated, used,
                        time.monotonic() - t0, note)
            prev_best = out.after
            out.steps.append(step)
            if not last_fail:
                bias = runs.mean(0) - (objective.emulator.mu0 + _emulated_diff(cands, x))
            if not last_fail and error < out.after:
                out.after = error
                for p, v in zip(out.params, x, strict=True):
                    p.value = float(v)
                out.bias = bias
                out.bias_var = (runs.var(0, ddof=1) / len(runs) if len(runs) > 1
                                else np.zeros(runs.shape[1]))
            if progress is not None:
                per_eval = step.elapsed_s / (used / per)
                progress(out.progress(per_eval * max(0, (budget - used) // per)))
            if last_fail:
                continue
            if not _above_floor(objective, out, out.after, out.strengths):
                out.stop = 'floor'
                return
            if prev_best - out.after < MIN_GAIN * max(objective.floor.above(prev_best), 1e-12):
                out.stop = 'stalled'
                return
    except KeyboardInterrupt:
        out.stop = 'interrupted'


def _above_floor(objective: Objective, out: Recalibration, error: float,
                 strengths: tuple[float, ...]) -> bool:
    """Whether ``error`` lies above the like-for-like floor band of the model at ``strengths``
    (recorded in ``out.floor_bands``), or above the nominal chi^2 mean where no band can be
    computed."""
    band = objective.floor_band(strengths) if objective.floor_band is not None else None
    if band is None:
        return error > objective.floor.k
    place = band.place(error)
    out.floor_bands.append({'iteration': len(out.steps) - 1, 'strengths': list(strengths),
                            'error': error, 'place': place, **band.to_json(1.0)})
    return place == 'above'


def _emulated_diff(cands: Sequence[CandidateEmulator], x: F64) -> F64:
    """(k,) the emulator's summed paired difference at strengths ``x``."""
    return np.asarray(np.sum([c.predict(np.array([v], np.float64))[0][0]
                              for c, v in zip(cands, x, strict=True)], axis=0), np.float64)
