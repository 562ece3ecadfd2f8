"""Which run would best separate two rival answers: where their predictions differ most.

When two answers remain (two candidates, or a candidate and "nothing missing"), the decision
between them rests on their emulated responses: each candidate's statistics are simulated at a
few strengths and interpolated between them. A new run changes the decision where three things
hold at once (issue 32):

- the candidate is plausible there: its likelihood at that strength, relative to its best
  (``weight``; a run where the data already rule it out moves nothing);
- the rivals' predictions differ there, measured over the spread of one pass (seed spread,
  grain sampling, noise and allowance): ``z_k = |mu_X(x) - mu_Y|_k / sqrt(v_X,k(x) + v_Y,k)``
  on each measured statistic k, with Y at its own fit; where they agree, no run tells them apart;
- the prediction there is interpolated, not simulated: ``novelty``, the distance from the
  nearest simulated strength over ``GAP`` of the library's span, capped at 1 (a strength
  already simulated has its paired mean; another run on the same seeds repeats it).

The score of a run of candidate X at strength x is ``weight * novelty * sum_k z_k^2``, over a
grid of X's plausible strengths (the posterior mean +- ``REACH`` sd, inside the physical range
and at most one library span beyond the simulated strengths). The best run of either rival is
planned.

Whether any run can settle the pair is judged where both explain the measurement, at their fits:
if the truth is A, one pass gives an expected log Bayes factor of ``D^2 / 2`` for A over B, with
``D^2 = delta^T S^-1 delta`` (delta the difference of their predictions at their best
strengths, S the mean of their covariances of one pass: seed spread, grain sampling, emulator,
noise and allowance). Naming needs odds of ``CONFIDENT / (1 - CONFIDENT)`` (4 to 1), so a pair
with ``D < sqrt(2 ln 4) = 1.67`` (``D_NEEDED``), each simulated at its fit, cannot be separated
confidently by one pass, whatever is run: the answer stays open with that reason.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dempath_diagnose.decision.diagnosis import Diagnosis
from dempath_diagnose.decision.emulator import CandidateEmulator
from dempath_diagnose.decision.verdict import CONFIDENT, ModelFit, gauss_logpdf
from dempath_diagnose.records import F64
from dempath_sim.effects.candidates import LOG_SCALE

GAP = 0.15  # a strength this fraction of the span from every simulated one is fully new
REACH = 2.0  # plausible strengths: the posterior mean +- this many sd
POINTS = 41  # grid points per candidate
PLAUSIBLE = 0.05  # likelihood relative to the best below which a strength is not considered
# one pass separates a pair with expected odds CONFIDENT : 1 - CONFIDENT at this distance [sd]
D_NEEDED = float(np.sqrt(2.0 * np.log(CONFIDENT / (1.0 - CONFIDENT))))


@dataclass(frozen=True)
class PairRun:
    """The best separating run of a rival pair.

    Attributes:
        candidate: Effect to run.
        strength: Strength to run it at (SI unit of its parameter).
        rival: The other answer of the pair (an effect name or ``baseline``).
        z_max: Largest |difference| over the spread on one statistic at that strength [sd].
        statistic: The statistic where it is largest.
        score: weight * novelty * sum of z^2.
    """

    candidate: str
    strength: float
    rival: str
    z_max: float
    statistic: str
    score: float


@dataclass(frozen=True)
class PairSeparation:
    """What runs can do for a rival pair.

    Attributes:
        best: The best new run (None: none is new where a rival is plausible).
        distance: D, the pair's distance at their fits over the covariance of one pass [sd].
        z_max: Their largest difference at their fits on one statistic [sd].
        statistic: The statistic where it is largest.
    """

    best: PairRun | None
    distance: float
    z_max: float
    statistic: str


def _grid(fit: ModelFit, ce: CandidateEmulator) -> F64:
    """X's plausible strengths: mean +- REACH sd, in its physical range and within one library
    span of the simulated strengths (on the interpolation axis)."""
    u0, u1 = float(ce.knots[0]), float(ce.knots[-1])
    span = (u1 - u0) or 1.0
    log = ce.candidate.name in LOG_SCALE
    mean = np.log(fit.strength) if log else fit.strength
    sd = fit.strength_sd / fit.strength if log and fit.strength > 0 else fit.strength_sd
    sd = max(float(sd), 0.02 * span)
    lo = max(mean - REACH * sd, u0 - span)
    hi = min(mean + REACH * sd, u1 + span)
    c = ce.candidate
    lo_phys = np.log(max(c.low, 1e-300)) if log else c.low
    hi_phys = np.log(c.high) if log else c.high
    u = np.linspace(max(lo, lo_phys), min(hi, hi_phys), POINTS)
    return np.exp(u) if log else u


def candidate_runs(d: Diagnosis, fit: ModelFit, rival: ModelFit) -> list[PairRun]:
    """Every grid strength of ``fit``'s candidate scored against ``rival`` (see module doc)."""
    ce = d.emulator.candidate_emulator(fit.name)
    emu, obs = d.emulator, d.observed
    xs = _grid(fit, ce)
    diffs, dvar = ce.predict(xs)
    own = emu.own_cov(d.cov, ce, xs)
    y_pred, y_var = rival.prediction, rival.pred_var  # at its fit (the baseline: its mean)
    logps = np.empty(len(xs))
    for i in range(len(xs)):
        total = own[i][np.ix_(obs, obs)] + np.diag(dvar[i][obs])
        logps[i] = gauss_logpdf(d.measured - (emu.mu0 + diffs[i])[obs], total)[0]
    weight = np.exp(logps - logps.max())
    u = ce.transform(xs)
    span = float(ce.knots[-1] - ce.knots[0]) or 1.0
    gaps = np.min(np.abs(u[:, None] - ce.knots[None, :]), axis=1) / span
    novelty = np.clip(gaps / GAP, 0.0, 1.0)
    names = np.array(emu.names)[obs]
    out = []
    for i, x in enumerate(xs):
        var = np.diag(own[i]) + dvar[i]
        z = np.abs(emu.mu0 + diffs[i] - y_pred)[obs] / np.sqrt(var + y_var)[obs]
        k = int(np.argmax(z)) if len(z) else 0
        z_max = float(z[k]) if len(z) else 0.0
        score = float(weight[i] * novelty[i] * np.sum(z**2)) if weight[i] >= PLAUSIBLE else 0.0
        out.append(PairRun(fit.name, float(x), rival.name, z_max if weight[i] >= PLAUSIBLE
                           else 0.0, str(names[k]) if len(z) else '', score))
    return out


def _fit_cov(d: Diagnosis, fit: ModelFit) -> F64:
    """(k, k) covariance of one pass of ``fit``'s model at its best strength."""
    if fit.kind == 'baseline':
        return np.asarray(d.emulator.own_cov(d.cov, None, np.zeros(1))[0], np.float64)
    ce = d.emulator.candidate_emulator(fit.name)
    _, dvar = ce.predict(np.array([fit.best]))
    own = d.emulator.own_cov(d.cov, ce, np.array([fit.best]))[0]
    return np.asarray(own + np.diag(dvar[0]), np.float64)


def pair_distance(d: Diagnosis, a: ModelFit, b: ModelFit) -> tuple[float, float, str]:
    """(D, largest single-statistic z, its statistic) of two answers at their fits (module
    docstring), on the measured statistics."""
    obs = d.observed
    delta = (a.prediction - b.prediction)[obs]
    cov = 0.5 * (_fit_cov(d, a) + _fit_cov(d, b))[np.ix_(obs, obs)]
    d2 = gauss_logpdf(delta, cov)[1] if len(delta) else 0.0
    z = np.abs(delta) / np.sqrt(np.diag(cov)) if len(delta) else np.zeros(1)
    k = int(np.argmax(z))
    names = np.array(d.emulator.names)[obs]
    return float(np.sqrt(d2)), float(z[k]), str(names[k]) if len(delta) else ''


def separate_pair(d: Diagnosis, a: ModelFit, b: ModelFit,
                  done: set[tuple[str, float]]) -> PairSeparation:
    """The best new run of either rival to separate ``a`` from ``b``, and how far apart they
    are at their fits (see the module docstring).

    Args:
        d: The current diagnosis.
        a, b: The rivals (a candidate or the baseline each; at least one a candidate).
        done: (candidate, strength) already run by the adaptive loop.
    """
    distance, z_max, statistic = pair_distance(d, a, b)
    runs = [r for fit, rival in ((a, b), (b, a)) if fit.kind != 'baseline'
            for r in candidate_runs(d, fit, rival)]
    new = [r for r in runs if r.score > 0.0 and (r.candidate, round(r.strength, 9)) not in done]
    best = max(new, key=lambda r: r.score) if new else None
    return PairSeparation(best, distance, z_max, statistic)


__all__ = ['D_NEEDED', 'GAP', 'PairRun', 'PairSeparation', 'candidate_runs', 'pair_distance',
           'separate_pair']
