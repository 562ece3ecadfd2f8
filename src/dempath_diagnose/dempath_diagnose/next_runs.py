"""Which simulations would settle an open diagnosis: past the library's edge, or between rivals.

A diagnosis rests on the signature library's runs: each candidate's response is simulated at a
few strengths and interpolated between them, extrapolated a quarter of the span beyond. Two
situations leave the answer open that more simulations can close (issue 32):

- **Past the edge.** A candidate's fit peaks at the end of its strength range away from the
  scene's value (``ModelFit.at_range_edge``): the data ask for more than the library spans. The
  next strength comes from the emulator's trend: along the end segment of the paired response,
  extended as a straight line, the strength whose prediction fits the measured statistics best
  (generalised least squares under the covariance of the last simulated strength), at least
  past the current range and at most one library span beyond the last simulated strength,
  inside the physical range.
- **Between rivals.** Two or more answers are not ruled out and none is named. The two most
  probable ("nothing missing" among them) are a pair; the run that best separates them is the
  one where a rival is plausible, its prediction is interpolated and the pair's predictions
  differ most over the spread of one pass (:mod:`dempath_diagnose.separation`). When they
  differ by less than 1 sd wherever they are plausible, no run separates them (the reason says
  how far apart they come). When no new run would separate the pair: where a contender's
  fitted strength lies between the simulated strengths, its prediction there is an
  interpolation, with the emulator's variance on top; a run at the fitted strength replaces the
  interpolation by paired simulations exactly where the decision is made, for each contender
  (most probable first; the most probable answer counts even when ruled out: its interpolated
  response, not the effect, may be what fails). A fit beyond the last simulated strength (an
  extrapolation) gets a run when it lies more than 3 % of the span beyond it; one between
  simulated strengths when it lies more than 15 % of the span from both. When every contender
  is already simulated at its fit, more runs of this design cannot move the probabilities: the
  answer stays open, with the reason (how far apart the rivals' predictions are, in sd of seed
  spread and allowance, and what would separate them).

Nothing here runs a simulation; :mod:`dempath_diagnose.adaptive` runs the plan.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dempath_diagnose.decision.diagnosis import Diagnosis
from dempath_diagnose.decision.emulator import CandidateEmulator
from dempath_diagnose.decision.verdict import ModelFit
from dempath_diagnose.separation import (
    D_NEEDED,
    PairRun,
    PairSeparation,
    pair_distance,
    separate_pair,
)
from dempath_sim.effects.candidates import LOG_SCALE

NAMED = ('effect_missing', 'parameter_off')
CONTENDER_P = 0.05  # an answer with at least this probability, not ruled out, is a contender
GAP = 0.15  # a fit farther than this fraction of the span from every simulated strength gets one
NEAR = 0.03  # ... or farther than this beyond the last simulated strength (an extrapolation)
STEP_MIN = 0.25  # past the edge: at least this fraction of the span beyond the last strength
STEP_MAX = 1.0  # ... and at most this fraction


@dataclass(frozen=True)
class PlannedRun:
    """One strength of one candidate to simulate on the library's seeds.

    Attributes:
        candidate: Effect name.
        strength: Strength to run (SI unit of the candidate's parameter).
        why: ``past_edge`` or ``separate``.
        reason: One sentence: what was seen and why this run.
    """

    candidate: str
    strength: float
    why: str
    reason: str


@dataclass(frozen=True)
class Plan:
    """The next runs, or none with the reason to stop.

    Attributes:
        runs: Strengths to simulate (empty: stop).
        stop: Why nothing more is run (empty while runs are planned).
    """

    runs: tuple[PlannedRun, ...] = ()
    stop: str = ''


def _u(ce: CandidateEmulator, x: float) -> float:
    return float(ce.transform(np.array([x]))[0])


def _x(ce: CandidateEmulator, u: float) -> float:
    return float(np.exp(u)) if ce.candidate.name in LOG_SCALE else float(u)


def _span(ce: CandidateEmulator) -> float:
    return float(ce.knots[-1] - ce.knots[0]) or 1.0


def trend_strength(d: Diagnosis, ce: CandidateEmulator, high: bool) -> float:
    """The strength past the library's edge that the emulator's trend says fits best (see the
    module docstring), in the candidate's physical range."""
    knots, diffs = ce.knots, ce.diffs
    end, prev = (-1, -2) if high else (0, 1)
    slope = (diffs[end] - diffs[prev]) / (knots[end] - knots[prev])
    obs = d.observed
    r = d.measured - (d.emulator.mu0 + diffs[end])[obs]
    s = slope[obs]
    own = d.emulator.own_cov(d.cov, ce, np.array([_x(ce, float(knots[end]))]))[0]
    total = own[np.ix_(obs, obs)] + np.diag(ce.diff_var[end][obs])
    w_s = np.linalg.solve(total, s)
    denom = float(s @ w_s)
    direction = 1.0 if high else -1.0
    step = float(w_s @ r) / denom * direction if denom > 0 else STEP_MAX * _span(ce)
    span = _span(ce)
    step = float(np.clip(step, STEP_MIN * span, STEP_MAX * span))
    x = _x(ce, float(knots[end]) + direction * step)
    return float(np.clip(x, ce.candidate.low, ce.candidate.high))


def _past_edge(d: Diagnosis, fit: ModelFit) -> PlannedRun | None:
    ce = d.emulator.candidate_emulator(fit.name)
    high = fit.best >= ce.candidate.current
    last = _x(ce, float(ce.knots[-1 if high else 0]))
    x = trend_strength(d, ce, high)
    if np.isclose(x, last, rtol=1e-6):
        return None  # at the physical limit: nothing beyond to run
    side = 'above' if high else 'below'
    reason = (f'{fit.name} fits best at the edge of the library ({fit.best:.4g} {fit.unit}, '
              f'range {fit.strength_range[0]:.4g}-{fit.strength_range[1]:.4g}); the trend of '
              f'its response {side} the last simulated strength {last:.4g} fits best at '
              f'{x:.4g}: running it there')
    return PlannedRun(fit.name, x, 'past_edge', reason)


def _at_fit(d: Diagnosis, fit: ModelFit) -> PlannedRun | None:
    ce = d.emulator.candidate_emulator(fit.name)
    x = float(np.clip(fit.strength, ce.candidate.low, ce.candidate.high))
    u = _u(ce, x)
    gaps = np.abs(ce.knots - u) / _span(ce)
    outside = u < ce.knots[0] or u > ce.knots[-1]
    if float(gaps.min()) <= (NEAR if outside else GAP):
        return None
    lower = [_x(ce, float(k)) for k in ce.knots if k < u]
    upper = [_x(ce, float(k)) for k in ce.knots if k > u]
    between = (f'between the simulated {lower[-1]:.4g} and {upper[0]:.4g}' if lower and upper
               else 'beyond the simulated strengths')
    state = 'ruled out there' if fit.ruled_out else f'p {fit.probability:.2f}'
    reason = (f'{fit.name} ({state}) fits at {x:.4g} {fit.unit}, {between}: its prediction '
              'there is interpolated; a paired run there replaces it')
    return PlannedRun(fit.name, x, 'separate', reason)


def _cannot_separate(d: Diagnosis, contenders: list[ModelFit]) -> str:
    """Why more runs of this design would not separate the contenders."""
    names = [f.name for f in contenders]
    obs = d.observed
    fits = {f.name: f for f in [d.decision.baseline, *d.decision.ranking]}
    worst = 0.0
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            fa, fb = fits[a], fits[b]
            spread = np.sqrt(fa.pred_var + fb.pred_var)[obs]
            z = np.abs(fa.prediction - fb.prediction)[obs] / spread
            worst = max(worst, float(z.max()) if len(z) else 0.0)
    hint = '; '.join(d.decision.separators[:1])
    return (f'the data cannot separate {" and ".join(names)}: each is simulated at its fitted '
            f'strength and their predictions differ by at most {worst:.1f} sd (seed spread, '
            f'sampling, noise and allowance) on the measured statistics'
            + (f'; what would: {hint}' if hint else ''))


def _contenders(d: Diagnosis) -> list[ModelFit]:
    """Candidates still in the running: not ruled out with probability >= CONTENDER_P, and the
    most probable one even when ruled out (its interpolated response may be what fails)."""
    ranking = d.decision.ranking
    out = [f for f in ranking if not f.ruled_out and f.probability >= CONTENDER_P]
    if ranking and ranking[0].probability >= CONTENDER_P and ranking[0] not in out:
        out.insert(0, ranking[0])
    return out


def _rival_pair(d: Diagnosis, plausible: list[ModelFit]) -> tuple[ModelFit, ModelFit] | None:
    """The two most probable answers not ruled out (with at least CONTENDER_P each), "nothing
    missing" among them; None when fewer than two remain."""
    base = d.decision.baseline
    rivals = [f for f in plausible if f.probability >= CONTENDER_P]
    if not base.ruled_out and base.probability >= CONTENDER_P:
        rivals.append(base)
    rivals.sort(key=lambda f: -f.probability)
    return (rivals[0], rivals[1]) if len(rivals) >= 2 else None


def _pair_run(d: Diagnosis, run: PairRun, sep: PairSeparation) -> PlannedRun:
    fits = {f.name: f for f in [d.decision.baseline, *d.decision.ranking]}
    fit = fits[run.candidate]
    rival = 'nothing missing' if run.rival == 'baseline' else run.rival
    unit = f' {fit.unit}' if fit.unit not in ('', '1') else ''
    reason = (f'{run.candidate} (p {fit.probability:.2f}) and {rival} '
              f'(p {fits[run.rival].probability:.2f}) remain, {sep.distance:.2f} sd apart at '
              f'their fits; the run that best separates them is {run.candidate} at '
              f'{run.strength:.4g}{unit}: plausible there, interpolated there, and its '
              f'prediction differs from that of {rival} by up to {run.z_max:.1f} sd of one '
              f'pass ({run.statistic})')
    return PlannedRun(run.candidate, run.strength, 'separate', reason)


def _distance_note(pair: tuple[ModelFit, ModelFit], sep: PairSeparation) -> str:
    names = ' and '.join('nothing missing' if f.name == 'baseline' else f.name for f in pair)
    return (f'{names} lie {sep.distance:.2f} sd apart at their fits (Mahalanobis, over the '
            f'spread of one pass: seed spread, sampling, emulator, noise and allowance; one '
            f'statistic at most {sep.z_max:.1f} sd, {sep.statistic}); one pass names one of '
            f'them confidently from {D_NEEDED:.2f} sd')


def _inseparable(pair: tuple[ModelFit, ModelFit], sep: PairSeparation) -> str:
    names = ' and '.join('nothing missing' if f.name == 'baseline' else f.name for f in pair)
    return (f'the data cannot separate {names}: each is simulated at its fit and '
            + _distance_note(pair, sep) + ': no run of these candidates tells them apart on '
            'this measurement')


def plan_next(d: Diagnosis, budget_left: int, done: set[tuple[str, float]]) -> Plan:
    """The next runs for diagnosis ``d`` (see the module docstring), or the reason to stop.

    Args:
        d: The current diagnosis.
        budget_left: Simulations still allowed.
        done: (candidate, strength) already run by the adaptive loop (never run twice).
    """
    dec = d.decision
    top = dec.ranking[0]
    if budget_left <= 0:
        pair = (_rival_pair(d, [f for f in _contenders(d) if not f.ruled_out])
                if dec.verdict == 'inconclusive' else None)
        note = (f'; {_distance_note(pair, PairSeparation(None, *pair_distance(d, *pair)))}'
                if pair else '')
        return Plan(stop='the budget of simulations is spent' + note)
    if dec.verdict == 'nothing_significant':
        return Plan(stop='"nothing missing" is the most probable answer and the model is not '
                         'ruled out: nothing to look for')
    if dec.verdict in NAMED and not top.at_range_edge:
        return Plan(stop=f'{top.name} is named (p {top.probability:.2f})')

    def new(runs: list[PlannedRun | None]) -> tuple[PlannedRun, ...]:
        return tuple(r for r in runs
                     if r is not None and (r.candidate, round(r.strength, 9)) not in done)

    contenders = _contenders(d)
    edge = new([_past_edge(d, f) for f in contenders if f.at_range_edge])
    if edge:
        return Plan(edge)
    if dec.verdict in NAMED:
        return Plan(stop=f'{top.name} is named (p {top.probability:.2f}); its fit lies at the '
                         'edge of its physical range, nothing beyond to run')
    plausible = [f for f in contenders if not f.ruled_out]
    pair = _rival_pair(d, plausible)
    if pair:
        sep = separate_pair(d, *pair, done)
        if sep.distance < D_NEEDED:  # confused where both fit: only their fits can move
            at_pair = new([_at_fit(d, f) for f in pair if f.kind != 'baseline'])
            return Plan(at_pair) if at_pair else Plan(stop=_inseparable(pair, sep))
        if sep.best is not None:
            return Plan((_pair_run(d, sep.best, sep),))
    at_fit = new([_at_fit(d, f) for f in contenders])
    if at_fit:
        return Plan(at_fit)
    if not plausible and dec.baseline.ruled_out:
        return Plan(stop=f'{top.name} fits best (p {top.probability:.2f}) but is ruled out '
                         f'even where it is simulated at its fit (implausibility '
                         f'{top.implausibility:.1f} > 3), as is every other answer: no single '
                         'candidate of the library explains the measurement (two effects at '
                         'once, or one the library does not hold)')
    rivals = ([dec.baseline] if not dec.baseline.ruled_out
              and dec.baseline.probability >= CONTENDER_P else []) + plausible
    if len(rivals) < 2:
        rivals = [dec.baseline, *plausible, *[f for f in dec.ranking if f not in plausible]][:2]
    return Plan(stop=_cannot_separate(d, rivals))


__all__ = ['CONTENDER_P', 'GAP', 'Plan', 'PlannedRun', 'plan_next', 'trend_strength']
