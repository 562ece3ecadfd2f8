"""The recalibration loop: fit the named candidate, confirm with real runs, stop at the floor.

One parameter (the diagnosis' candidate): a bounded scalar search (scipy's ``minimize_scalar``,
method ``bounded``) of the objective d^2 on the diagnosis' emulator over the candidate's prior
range, then a confirming real evaluation at the proposed strength. Each real evaluation runs the
candidate on the library's packing seeds and is *paired* with the library's baseline runs on the
same seeds (the baseline's mean over all seeds minus its mean over those seeds is added), so the
chaos of a few packings cancels and does not steer the fit. After each real evaluation the
emulator is corrected by the observed bias (real minus emulated statistics at that strength,
Kennedy & O'Hagan's discrepancy idea in its simplest form) and the search runs again.

Stops: at the floor (d^2 no longer significantly above chi^2_k, :mod:`objective`), at the budget
of simulations, when the error stops falling (less than ``MIN_GAIN`` of the error above the
floor removed by an iteration), or on Ctrl-C (the best strength so far is returned). A candidate
whose simulation fails (an unstable run) is scored as failed and the next proposal moves half way
back towards the scene's current value.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import minimize_scalar
from scipy.stats import chi2

from dempath_diagnose.decision import fit_candidate
from dempath_diagnose.emulator import CandidateEmulator
from dempath_diagnose.errors import DiagnosisError
from dempath_diagnose.library import LOG_SCALE
from dempath_diagnose.objective import Objective
from dempath_diagnose.records import F64

CHANGE_D2 = float(chi2.ppf(0.95, 1))  # a one-parameter fit must lower d^2 this much to count
MIN_GAIN = 0.05  # an iteration that removes less of the error above the floor ends the loop



class SweepLostError(DiagnosisError):
    """The simulations' scheduler went away mid-sweep (the loop stops; the best so far is kept)."""


Evaluate = Callable[[float], F64]  # strength -> (S, k) paired-corrected statistics per seed


@dataclass(frozen=True)
class Step:
    """One iteration: what was tried and what it gave.

    Attributes:
        iteration: 0 for the scene as it is, then 1, 2, ...
        strength: The candidate's strength (the scene's current value at iteration 0).
        error: d^2 of the real runs (inf for a failed candidate).
        emulated: d^2 the emulator predicted.
        simulations: Simulations used so far.
        elapsed_s: Wall time so far [s].
        note: '' or why the step failed.
    """

    iteration: int
    strength: float
    error: float
    emulated: float
    simulations: int
    elapsed_s: float
    note: str = ''


@dataclass
class Recalibration:
    """The loop's result.

    Attributes:
        effect: Candidate name; parameter, unit: its main parameter.
        before, after: d^2 of the scene as it is and with the fitted strength.
        floor_k, floor_significant: The floor (mean of chi^2_k) and its significance line.
        strength, strength_sd: Fitted strength and its uncertainty (posterior sd).
        steps: Every iteration.
        stop: ``floor``, ``budget``, ``stalled``, ``interrupted`` or ``nothing_to_fit``.
        changed: Whether the scene changes.
    """

    effect: str
    parameter: str
    unit: str
    before: float
    after: float
    floor_k: int
    floor_significant: float
    strength: float
    strength_sd: float
    current: float
    steps: list[Step] = field(default_factory=list)
    stop: str = ''
    changed: bool = False
    failures: int = 0
    note: str = ''

    @property
    def reduction(self) -> float:
        """Fraction of the error above the floor removed (1: down to the floor)."""
        above = max(0.0, self.before - self.floor_k)
        if above == 0.0:
            return 0.0
        return float(np.clip((self.before - self.after) / above, -np.inf, 1.0))


def propose(objective: Objective, cand: CandidateEmulator, bias: F64 | None = None) -> float:
    """The strength minimising the emulated d^2 (plus a bias correction) in the prior range."""
    lo, hi = cand.prior
    log = cand.candidate.name in LOG_SCALE

    def f(u: float) -> float:
        x = float(np.exp(u)) if log else u
        diff, var = cand.predict(np.array([x], np.float64))
        pred = objective.emulator.mu0 + diff[0] + (0.0 if bias is None else bias)
        return objective.d2(pred, var[0])

    a, b = (np.log(lo), np.log(hi)) if log else (lo, hi)
    res = minimize_scalar(f, bounds=(a, b), method='bounded', options={'xatol': 1e-3 * (b - a)})
    return float(np.exp(res.x)) if log else float(res.x)


def check_strength(cand: CandidateEmulator, value: float) -> None:
    """DiagnosisError when ``value`` lies outside the effect's physical range."""
    c = cand.candidate
    if not (np.isfinite(value) and c.low <= value <= c.high):
        msg = (f'{c.name}.{c.parameter} = {value:g} {c.unit}: outside the physical range '
               f'[{c.low:g}, {c.high:g}]')
        raise DiagnosisError(msg)


def unchanged(objective: Objective, cand: CandidateEmulator) -> Recalibration:
    """The scene as it is (iteration 0 only, stop ``nothing_to_fit``): the control's answer."""
    floor, c = objective.floor, cand.candidate
    before = objective.baseline()
    out = Recalibration(c.name, c.parameter, c.unit, before, before, floor.k, floor.significant,
                        c.current, 0.0, c.current, stop='nothing_to_fit')
    out.steps.append(Step(0, c.current, before, before, 0, 0.0))
    return out


def recalibrate(objective: Objective, cand: CandidateEmulator, evaluate: Evaluate,
                budget: int, seeds_per_eval: int,
                progress: Callable[[Step, float], None] | None = None,
                start: float | None = None) -> Recalibration:
    """Fit ``cand``'s strength; ``evaluate`` runs the real simulations (see the module docstring).

    Raises:
        DiagnosisError: A budget below one evaluation.
    """
    if budget < seeds_per_eval or budget <= 0:
        raise DiagnosisError(f'--budget {budget}: at least {seeds_per_eval} simulations '
                             '(one evaluation over the packing seeds) are needed')
    t0 = time.monotonic()
    out = unchanged(objective, cand)
    if out.before <= objective.floor.k:
        return out
    fit = fit_candidate(objective.emulator, cand, objective.y, objective.observed, objective.cov)
    out.stop, out.strength_sd = '', fit.strength_sd
    _loop(out, objective, cand, evaluate, (budget, seeds_per_eval), progress, t0, start)
    out.changed = out.before - out.after > CHANGE_D2
    if not out.changed:
        out.strength, out.strength_sd = out.current, 0.0
    return out


def _loop(out: Recalibration, objective: Objective, cand: CandidateEmulator, evaluate: Evaluate,
          sizes: tuple[int, int], progress: Callable[[Step, float], None] | None,
          t0: float, start: float | None) -> None:
    """Propose, evaluate, correct until a stop; fills ``out`` in place."""
    budget, per = sizes
    bias: F64 | None = None
    used, x, last_fail = 0, 0.0, False
    floor = objective.floor
    try:
        while True:
            if used + per > budget:
                out.stop = 'budget'
                return
            if start is not None and len(out.steps) == 1:
                x = start
            elif last_fail:
                x = (x + cand.candidate.current) / 2
            else:
                x = propose(objective, cand, bias)
            emulated = objective.emulated(cand, x)
            note, last_fail = '', False
            try:
                runs = evaluate(x)
                error = objective.real(runs)
            except SweepLostError as err:
                out.stop, out.note = 'scheduler_lost', str(err)
                return
            except DiagnosisError as err:
                error, note, last_fail = float('inf'), f'failed: {err}', True
                out.failures += 1
            used += per
            step = Step(len(out.steps), x, error, emulated, used, time.monotonic() - t0, note)
            prev_best = out.after
            out.steps.append(step)
            if progress is not None:
                per_eval = step.elapsed_s / (used / per)
                progress(step, per_eval * max(0, (budget - used) // per))
            if last_fail:
                continue
            if error < out.after:
                out.after, out.strength = error, x
            diff, _ = cand.predict(np.array([x], np.float64))
            bias = runs.mean(0) - (objective.emulator.mu0 + diff[0])
            if out.after <= floor.k:
                out.stop = 'floor'
                return
            if prev_best - out.after < MIN_GAIN * max(floor.above(prev_best), 1e-12):
                out.stop = 'stalled'
                return
    except KeyboardInterrupt:
        out.stop = 'interrupted'
