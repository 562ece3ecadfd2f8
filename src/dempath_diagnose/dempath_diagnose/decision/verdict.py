"""The decision: model probabilities, history-matching implausibility and the verdict.

Every candidate and the baseline ("nothing missing") is a model. The likelihood of the measured
statistics y under a candidate at strength x is Gaussian, N(y; mu0 + D(x), C(x) + V(x)), with C(x)
the covariance of seed, sampling, noise and discrepancy (:mod:`.emulator`) and V(x) the emulator's
variance. The seed part of C(x) takes the level of the seed spread at x
(:func:`~dempath_diagnose.decision.emulator.spread_levels`) and the sampling part the grain scatter
of the model at x: a cohesive bed's grains scatter more about their neighbourhood's motion, and its
beds vary more from seed to seed, than a loose bed's (the baseline takes its own). The prior is a
spike and slabs: the baseline (no free strength) and each candidate's strength range (uniform, GRID
points; log-uniform for LOG_SCALE effects), equal prior mass each. A candidate contains the
baseline (its strength at the current value), so the answers are made mutually exclusive by what
the data can resolve: the strengths at which a candidate's prediction lies within one standard
deviation of the baseline's (Mahalanobis distance of D(x) under C + V(x) at most NULL_SD, a
Kullback-Leibler divergence of at most half a nat) are the baseline, and their posterior mass
counts for "nothing missing"; a candidate's probability is the posterior mass of its strengths that
the data can tell from the baseline. Without this, the probability of "nothing missing" is spread
over every candidate near its current value and the baseline rarely exceeds 1 / (candidates + 1)
even when nothing is missing. (A point mass on the null beside a continuous prior is the
spike-and-slab prior of Bayesian tests of nested models, Mitchell & Beauchamp 1988, JASA 83, 1023;
the uniform slab keeps each candidate's Occam factor.)

Implausibility (Vernon, Goldstein & Bower 2010, multivariate form): d^2 = r^T (C+V)^-1 r at the
best strength, converted to the Gaussian sigma of the same tail probability under chi^2(k); a
model with I > THRESHOLD (3) is ruled out.

Verdict:
- ``nothing_significant``: the baseline is not ruled out and "nothing missing" is the most
  probable answer;
- ``effect_missing`` / ``parameter_off``: the top candidate is not ruled out, has probability
  >= CONFIDENT and the baseline is ruled out or clearly worse;
- ``inconclusive`` otherwise, naming what is not ruled out and what would separate it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from scipy import stats
from scipy.special import logsumexp

from dempath_diagnose.decision.emulator import CandidateEmulator, Emulator
from dempath_diagnose.records import F64
from dempath_sim.effects.candidates import LOG_SCALE

GRID = 121  # strength grid points for the marginalisation
THRESHOLD = 3.0  # implausibility above which a model is ruled out [sigma]
CONFIDENT = 0.8  # probability for naming a single candidate
BAYES_CLEAR = 10.0  # 'clearly worse': a candidate this many times more probable
NULL_SD = 1.0  # a prediction within this many sd (Mahalanobis) of the baseline's is the baseline


@dataclass(frozen=True)
class ModelFit:
    """One model's fit to the measured statistics.

    Attributes:
        name: ``baseline`` or the candidate's effect name.
        kind: ``baseline``, ``effect`` or ``parameter``.
        log_evidence: log p(y, strength distinguishable from the baseline | model) (the
            baseline: log p(y | baseline)).
        log_null: log p(y, strength indistinguishable from the baseline | model) (-inf for the
            baseline itself): mass that counts for 'nothing missing'.
        implausibility: Gaussian-sigma implausibility at the best strength.
        strength: Posterior mean strength (NaN for the baseline).
        strength_sd: Posterior sd of the strength.
        best: Strength of the highest likelihood.
        prediction: (k,) predicted statistics at the best strength (all statistics).
        pred_var: (k,) their total variance.
        chi2: d^2 at the best strength.
        strength_range: (low, high) of the strengths searched (the library's span plus a
            quarter): the prior.
        at_range_edge: The likelihood peaks at an end of that range away from the scene's own
            value: the data ask for more than the library spans, the true strength may lie
            beyond and ``strength_sd`` understates the uncertainty.
    """

    name: str
    kind: str
    log_evidence: float
    implausibility: float
    strength: float
    strength_sd: float
    best: float
    prediction: F64
    pred_var: F64
    chi2: float
    probability: float = 0.0
    unit: str = ''
    parameter: str = ''
    explained_fraction: float = 0.0
    log_null: float = -np.inf
    strength_range: tuple[float, float] = (np.nan, np.nan)
    at_range_edge: bool = False

    @property
    def ruled_out(self) -> bool:
        """Whether the implausibility exceeds the threshold."""
        return self.implausibility > THRESHOLD


@dataclass(frozen=True)
class Decision:
    """The verdict and every model's fit, ranked most probable first (baseline apart)."""

    verdict: str
    ranking: list[ModelFit]
    baseline: ModelFit
    remaining: list[str] = field(default_factory=list)
    separators: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)  # why the verdict is weaker than the fits


def gauss_logpdf(r: F64, cov: F64) -> tuple[float, float]:
    """(log N(r; 0, cov), r^T cov^-1 r) via Cholesky."""
    chol = np.linalg.cholesky(cov)
    z = np.linalg.solve(chol, r)
    d2 = float(z @ z)
    logdet = 2.0 * float(np.sum(np.log(np.diag(chol))))
    return -0.5 * (d2 + logdet + len(r) * np.log(2 * np.pi)), d2


def sigma_of(d2: float, k: int) -> float:
    """The Gaussian sigma with the two-sided tail probability of chi^2_k beyond d2."""
    p = float(stats.chi2.sf(d2, k))
    return float(stats.norm.isf(max(p, 1e-300) / 2.0))


def fit_baseline(emu: Emulator, y: F64, obs: NDArray[np.bool_], cov: F64) -> ModelFit:
    """The baseline model's fit."""
    r = y - emu.mu0[obs]
    own = emu.own_cov(cov, None, np.zeros(1))[0]
    logp, d2 = gauss_logpdf(r, own[np.ix_(obs, obs)])
    return ModelFit('baseline', 'baseline', logp, sigma_of(d2, int(obs.sum())), np.nan,
                    np.nan, np.nan, emu.mu0.copy(), np.diag(own).copy(), d2)


def fit_candidate(emu: Emulator, cand: CandidateEmulator, y: F64, obs: NDArray[np.bool_],
                  cov: F64) -> ModelFit:
    """One candidate's fit, marginalised over its strength prior, split into the strengths the
    data can tell from the baseline and those it cannot (see the module docstring)."""
    lo, hi = cand.prior
    xs = np.asarray(np.geomspace(lo, hi, GRID) if cand.candidate.name in LOG_SCALE
                    else np.linspace(lo, hi, GRID), np.float64)
    diffs, dvar = cand.predict(xs)
    own = emu.own_cov(cov, cand, xs)  # the seed spread and grain scatter at each strength
    logps, d2s, shift2 = np.empty(GRID), np.empty(GRID), np.empty(GRID)
    for i in range(GRID):
        r = y - (emu.mu0 + diffs[i])[obs]
        total = own[i][np.ix_(obs, obs)] + np.diag(dvar[i][obs])
        logps[i], d2s[i] = gauss_logpdf(r, total)
        shift2[i] = gauss_logpdf(diffs[i][obs], total)[1]
    null = shift2 <= NULL_SD**2
    w = np.exp(logps - logsumexp(logps))
    u = np.log(xs) if cand.candidate.name in LOG_SCALE else xs
    mean_u = float(w @ u)
    sd_u = float(np.sqrt(max(w @ (u - mean_u) ** 2, 0.0)))
    if cand.candidate.name in LOG_SCALE:
        strength, sd = float(np.exp(mean_u)), float(np.exp(mean_u) * sd_u)
    else:
        strength, sd = mean_u, sd_u
    best = int(np.argmax(logps))
    c = cand.candidate
    edge = best in (0, GRID - 1) and not np.isclose(xs[best], c.current, rtol=1e-9, atol=0.0)
    return ModelFit(c.name, c.kind, _log_mass(logps[~null]),
                    sigma_of(float(np.min(d2s)), int(obs.sum())), strength, sd, float(xs[best]),
                    emu.mu0 + diffs[best],
                    np.diag(own[best]) + dvar[best],
                    float(d2s[best]),
                    unit=c.unit, parameter=c.parameter, log_null=_log_mass(logps[null]),
                    strength_range=(float(lo), float(hi)), at_range_edge=bool(edge))


def _log_mass(logps: F64) -> float:
    """log of (sum of exp(logps)) / GRID: prior-weighted likelihood mass of some grid points."""
    return float(logsumexp(logps) - np.log(GRID)) if len(logps) else -np.inf


def decide(emu: Emulator, y: F64, obs: NDArray[np.bool_], cov: F64) -> Decision:
    """Fit every model, give probabilities and the verdict (see the module docstring)."""
    base = fit_baseline(emu, y, obs, cov)
    fits = [fit_candidate(emu, c, y, obs, cov) for c in emu.candidates]
    nothing = logsumexp([base.log_evidence] + [f.log_null for f in fits])
    logs = np.array([nothing] + [f.log_evidence for f in fits])
    probs = np.exp(logs - logsumexp(logs))
    base = _with(base, probs[0], y, obs, base)
    fits = sorted((_with(f, p, y, obs, base) for f, p in zip(fits, probs[1:], strict=True)),
                  key=lambda f: -f.probability)
    top = fits[0]
    clearly_worse = top.probability > BAYES_CLEAR * base.probability
    if not base.ruled_out and base.probability >= top.probability:
        verdict = 'nothing_significant'
    elif (not top.ruled_out and top.probability >= CONFIDENT
          and (base.ruled_out or clearly_worse)):
        verdict = 'effect_missing' if top.kind == 'effect' else 'parameter_off'
    else:
        verdict = 'inconclusive'
    remaining = [f.name for f in ([base, *fits]) if not f.ruled_out]
    if verdict == 'inconclusive' and not remaining:
        remaining = [f.name for f in fits[:2]]
    seps = separators(emu, [f for f in fits if f.name in remaining][:3], obs) \
        if verdict == 'inconclusive' else []
    return Decision(verdict, fits, base, remaining, seps)


def _with(fit: ModelFit, p: float, y: F64, obs: NDArray[np.bool_], base: ModelFit) -> ModelFit:
    """``fit`` with its probability and the fraction of the significant discrepancy explained."""
    from dataclasses import replace

    def excess(pred: F64) -> float:
        z2 = (y - pred[obs]) ** 2 / base.pred_var[obs]
        return float(np.sum(np.clip(z2 - 1.0, 0.0, None)))

    before = excess(base.prediction)
    frac = (float(np.clip((before - excess(fit.prediction)) / before, 0.0, 1.0))
            if before > 0 and fit.kind != 'baseline' else 0.0)
    return replace(fit, probability=float(p), explained_fraction=frac)


def separators(emu: Emulator, fits: list[ModelFit], obs: NDArray[np.bool_]) -> list[str]:
    """What would separate the remaining candidates: the statistics their fits differ most on."""
    out = []
    for i, a in enumerate(fits):
        for b in fits[i + 1:]:
            z = np.abs(a.prediction - b.prediction) / np.sqrt(a.pred_var + b.pred_var)
            k = int(np.argmax(z))
            name = emu.names[k]
            what = ('a draft-force measurement' if name.startswith('force:') and not obs[k]
                    else f'the statistic {name}')
            out.append(f'{a.name} vs {b.name}: {what} (predictions differ by {z[k]:.1f} sd; '
                       f'{_fmt(name, a.prediction[k])} vs {_fmt(name, b.prediction[k])})')
    return out


def _fmt(name: str, value: float) -> str:
    return f'{value:.1f} N' if name.startswith('force:') else f'{value * 1e3:.1f} mm'
