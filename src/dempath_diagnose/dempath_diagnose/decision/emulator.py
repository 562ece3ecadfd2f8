"""The emulator: each model's predicted statistics and their covariance, as a function of strength.

For a layout, every library run becomes a statistic vector (:mod:`.statistics`, always with the
force statistics, so that what an unmeasured force would show can be said). Then:

- baseline mean mu0 = mean over seeds of the baseline vectors;
- a candidate at strength x: mu(x) = mu0 + D(x), with D the *paired* difference (candidate run
  minus baseline run on the same seed, averaged over seeds) at the library's strengths,
  interpolated piecewise-linearly in the strength (log strength for LOG_SCALE effects) through
  D(current) = 0, extrapolated linearly up to EXTEND of the library's span;
- the emulator's own variance: the seed variance of the paired differences over the number of
  seeds, interpolated alike;
- the seed covariance: residuals of every model's runs about that model's seed mean, pooled,
  shrunk with Ledoit-Wolf (few seeds, many statistics), with a level per strength
  (heteroscedastic seeds: a cohesive bed varies more from seed to seed than a loose one, a slow
  tool's less): the seed covariance at strength x is s(x) times the pooled shape, s estimated at
  each simulated strength from its own seeds over every statistic (:func:`spread_levels`),
  shrunk towards the pooled level and interpolated in strength;
- the sampling covariance of one particle per cube: each model and strength its own (the mean
  over its seeds; the grains of a cohesive bed scatter eight times more about their
  neighbourhood's motion than a loose bed's on the tiny scene), interpolated in strength; the
  mean over every run where one figure is wanted (the floor);
- measurement noise ``noise_m`` per axis over the markers of the group;
- the model-discrepancy allowance: ``discrepancy_m + discrepancy_rel * |mu0|`` for the marker
  statistics and ``discrepancy_force_rel * |mu0|`` for the draft, as an independent sd.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from dempath_diagnose.decision.statistics import Layout, model_statistics
from dempath_diagnose.library.simulator import Candidate
from dempath_diagnose.library.store import Library
from dempath_diagnose.records import F64
from dempath_sim.effects.candidates import LOG_SCALE

EXTEND = 0.25  # the prior range reaches this fraction of the library's span beyond it
SPREAD_PRIOR_DOF = 0.0  # the pooled seed spread's weight on one strength's own level [dof]
OWN_SAMPLING = True  # each strength its own grain scatter (False: the mean over every run)


@dataclass(frozen=True)
class Allowance:
    """Measurement noise and the model-discrepancy allowance (documented defaults).

    Attributes:
        noise_m: Measurement noise per axis of one marker [m] (a camera pair: 1.5 mm).
        discrepancy_m: Absolute allowance on a marker statistic [m].
        discrepancy_rel: Relative allowance on a marker statistic [1].
        discrepancy_force_rel: Relative allowance on the draft [1] (engines differ by ~9 %).
    """

    noise_m: float = 0.0015
    discrepancy_m: float = 0.002
    discrepancy_rel: float = 0.10
    discrepancy_force_rel: float = 0.10

    def __post_init__(self) -> None:
        for name in ('noise_m', 'discrepancy_m', 'discrepancy_rel', 'discrepancy_force_rel'):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0):
                raise ValueError(f'Allowance.{name}: must be >= 0, got {value!r}')


@dataclass(frozen=True)
class CandidateEmulator:
    """Paired-difference response of one candidate.

    Attributes:
        candidate: The candidate.
        knots: (j,) transformed strengths, the current value included (difference 0 there).
        diffs: (j, k) mean paired differences at the knots.
        diff_var: (j, k) variance of those means.
        prior: (lo, hi) strength range of the prior (untransformed).
        spread: (j,) seed-spread level at the knots, relative to the pooled seed covariance
            (None: 1 everywhere, the pooled covariance at every strength).
        sampling: (j, k, k) one-particle sampling covariance at the knots (None: the pooled
            one at every strength).
    """

    candidate: Candidate
    knots: F64
    diffs: F64
    diff_var: F64
    prior: tuple[float, float]
    spread: F64 | None = None
    sampling: F64 | None = None

    def transform(self, x: F64) -> F64:
        """Strength -> the axis of interpolation (log for LOG_SCALE effects)."""
        return np.log(x) if self.candidate.name in LOG_SCALE else np.asarray(x, np.float64)

    def predict(self, x: F64) -> tuple[F64, F64]:
        """(n, k) differences and their variance at strengths x (n,)."""
        u = self.transform(np.atleast_1d(x))
        mean = np.column_stack([_interp(u, self.knots, self.diffs[:, i])
                                for i in range(self.diffs.shape[1])])
        var = np.column_stack([_interp(u, self.knots, self.diff_var[:, i]).clip(0.0)
                               for i in range(self.diffs.shape[1])])
        return mean, var

    def spread_at(self, x: F64) -> F64:
        """(n,) seed-spread level at strengths x: interpolated in log between the knots, held
        at the end knots' levels beyond them (one strength's seeds say nothing of the trend)."""
        u = self.transform(np.atleast_1d(x))
        if self.spread is None:
            return np.ones(len(u))
        return np.asarray(np.exp(np.interp(u, self.knots, np.log(self.spread))), np.float64)

    def sampling_at(self, x: F64) -> F64 | None:
        """(n, k, k) sampling covariance at strengths x: linear between the knots (a mixture
        of covariances stays one), held at the end knots' beyond them; None when the knots have
        none (the pooled one applies)."""
        if self.sampling is None:
            return None
        u = np.clip(self.transform(np.atleast_1d(x)), self.knots[0], self.knots[-1])
        hi = np.clip(np.searchsorted(self.knots, u, side='right'), 1, len(self.knots) - 1)
        lo = hi - 1
        gap = self.knots[hi] - self.knots[lo]
        w = np.where(gap > 0, (u - self.knots[lo]) / np.where(gap > 0, gap, 1.0), 0.0)
        return np.asarray((1.0 - w)[:, None, None] * self.sampling[lo]
                          + w[:, None, None] * self.sampling[hi], np.float64)


def _interp(u: F64, knots: F64, values: F64) -> F64:
    """Piecewise-linear interpolation with linear extrapolation from the end segments."""
    if len(knots) == 1:
        return np.full(len(u), values[0])
    out = np.interp(u, knots, values)
    lo = u < knots[0]
    hi = u > knots[-1]
    slope_lo = (values[1] - values[0]) / (knots[1] - knots[0])
    slope_hi = (values[-1] - values[-2]) / (knots[-1] - knots[-2])
    out[lo] = values[0] + slope_lo * (u[lo] - knots[0])
    out[hi] = values[-1] + slope_hi * (u[hi] - knots[-1])
    return out


@dataclass
class Emulator:
    """Everything the decision needs for one layout.

    Attributes:
        names: (k,) statistic names (force statistics last).
        mu0: (k,) baseline mean.
        seed_cov: (k, k) shrunk seed covariance.
        sampling_cov: (k, k) one-particle-per-cube covariance.
        candidates: Per candidate emulators.
        baseline_runs: (S, k) baseline vectors per seed (for the floor and the plots).
        features0: (S, m, K, 3) baseline per-marker features (for the error map).
        feature_var: (m, K, 3) mean within-cube variance per marker.
        base_spread: Seed-spread level of the baseline's runs relative to ``seed_cov``.
        base_sampling: (k, k) sampling covariance of the baseline's runs (None: the mean over
            every run, ``sampling_cov``).
    """

    names: list[str]
    mu0: F64
    seed_cov: F64
    sampling_cov: F64
    candidates: list[CandidateEmulator]
    baseline_runs: F64
    features0: F64
    feature_var: F64
    runs: dict[str, F64] = field(default_factory=dict)
    base_spread: float = 1.0
    base_sampling: F64 | None = None

    def candidate_emulator(self, name: str) -> CandidateEmulator:
        """The emulator of the candidate ``name`` (StopIteration if the library has none)."""
        return next(c for c in self.candidates if c.candidate.name == name)

    def own_cov(self, cov: F64, cand: CandidateEmulator | None, x: F64) -> F64:
        """(n, k, k) ``cov`` (built on the pooled seed and sampling covariances) with the
        seed spread's level and the sampling covariance of the model at strengths x (the
        baseline's for ``cand`` None)."""
        n = len(np.atleast_1d(x))
        level: F64
        if cand is None:
            level = np.full(n, self.base_spread)
            samp = self.sampling_cov if self.base_sampling is None else self.base_sampling
            own = np.broadcast_to(samp, (n, *samp.shape))
        else:
            level = cand.spread_at(x)
            at = cand.sampling_at(x)
            own = np.broadcast_to(self.sampling_cov, (n, *cov.shape)) if at is None else at
        return (cov[None] + (level - 1.0)[:, None, None] * self.seed_cov[None]
                + own - self.sampling_cov[None])

    def is_force(self) -> NDArray[np.bool_]:
        """(k,) True for the draft statistics."""
        return np.array([n.startswith('force:') for n in self.names])

    def fixed_cov(self, allowance: Allowance, layout: Layout) -> F64:
        """Seed + sampling + noise + discrepancy covariance (k, k), strength-independent."""
        cov = self.seed_cov + self.sampling_cov
        diag = np.zeros(len(self.names))
        force = self.is_force()
        groups = {g.name: g for g in layout.groups}
        for i, name in enumerate(self.names):
            if force[i]:
                diag[i] = (allowance.discrepancy_force_rel * abs(self.mu0[i])) ** 2
            else:
                group, _, window = name.split(':')
                m = layout.group_count(groups[group], int(window.removeprefix('w')))
                diag[i] = (allowance.noise_m**2 / m
                           + (allowance.discrepancy_m
                              + allowance.discrepancy_rel * abs(self.mu0[i])) ** 2)
        return cov + np.diag(diag)


def build_emulator(library: Library, layout: Layout,
                   cube: tuple[float, float, float]) -> Emulator:
    """The emulator of ``library`` for ``layout`` (every run evaluated once)."""
    stats = {name: model_statistics(rec, layout, cube, with_force=True)
             for name, rec in library.records.items()}
    ((_, base_files),) = library.model_runs('').items()
    b = np.array([stats[f].vector for f in base_files])
    mu0 = b.mean(0)
    residuals = [b - mu0]  # one group per model and strength: the baseline's first
    base_sampling = np.mean([stats[f].sampling_cov for f in base_files], axis=0)
    responses = []
    for cand in library.candidates:
        runs = library.model_runs(cand.name)
        knots, diffs, dvar = [0.0], [np.zeros(len(mu0))], [np.zeros(len(mu0))]
        sampling = [base_sampling]
        for x, files in sorted(runs.items()):
            c = np.array([stats[f].vector for f in files])
            d = c - b[:len(c)]
            knots.append(x)
            sampling.append(np.mean([stats[f].sampling_cov for f in files], axis=0))
            diffs.append(d.mean(0))
            dvar.append(d.var(0, ddof=1) / len(d) if len(d) > 1 else np.abs(d.mean(0)) ** 2)
            residuals.append(c - c.mean(0))
        knots[0] = cand.current
        responses.append((cand, knots, diffs, dvar, sampling))
    levels = spread_levels(residuals)
    emulators, g = [], 1
    for cand, knots, diffs, dvar, sampling in responses:
        spread = np.concatenate([levels[:1], levels[g:g + len(knots) - 1]])
        g += len(knots) - 1
        order = np.argsort(knots)
        emu = CandidateEmulator(cand, np.zeros(0), np.array(diffs)[order],
                                np.array(dvar)[order], _prior(cand, knots), spread[order],
                                np.array(sampling)[order] if OWN_SAMPLING else None)
        emulators.append(replace(emu, knots=emu.transform(np.array(knots)[order])))
    unit = [r / np.sqrt(level) for r, level in zip(residuals, levels, strict=True)]
    seed_cov = _shrunk_cov(np.concatenate(unit), len(library.candidates) + 1)
    sampling = np.mean([s.sampling_cov for s in stats.values()], axis=0)
    feats = np.array([stats[f].features for f in base_files])
    fvar = np.nanmean([stats[f].feature_var for f in base_files], axis=0)
    return Emulator(layout.names(True), mu0, seed_cov, sampling, emulators, b, feats, fvar,
                    base_spread=float(levels[0]),
                    base_sampling=base_sampling if OWN_SAMPLING else None)


def spread_levels(groups: list[F64], prior_dof: float | None = None) -> F64:
    """Seed-spread level of each group of runs (one model at one strength) relative to the rest.

    Model: the seed covariance of group g is ``level_g`` times a common shape. With a handful of
    seeds per group one statistic's variance says little (2 degrees of freedom with 3 seeds), but
    every statistic of the group shares the level: the level is the median over the statistics
    of the group's variance over the common variance, divided by the median of chi^2_dof / dof
    (the median of a variance ratio when the level is 1); the common variance is the pool of
    every group's squares divided by its level (three alternations from levels of 1). Each
    level is then shrunk towards the pool's in log, with the weight dof / (dof + ``prior_dof``):
    the pool is worth ``prior_dof`` degrees of freedom of one group (a group of one run keeps the
    pool's level). The levels are scaled to a geometric mean of 1 over the groups.

    Args:
        groups: Residuals (n_g, k) of each group about its own seed mean.
        prior_dof: The pool's weight (None: SPREAD_PRIOR_DOF; infinity: every level 1, the
            pooled covariance at every strength).

    Returns:
        (G,) levels.
    """
    from scipy import stats as st

    nu0 = SPREAD_PRIOR_DOF if prior_dof is None else prior_dof
    dof = np.array([max(len(r) - 1, 0) for r in groups], np.float64)
    if not np.isfinite(nu0) or not np.any(dof > 0):
        return np.ones(len(groups))
    ss = np.array([np.sum(r**2, axis=0) for r in groups])
    levels: F64 = np.ones(len(groups))
    raw: F64 = np.ones(len(groups))
    for _ in range(3):
        common = np.sum(ss / levels[:, None], axis=0) / dof.sum()
        useful = common > 1e-12 * max(float(common.max()), 1e-300)
        for g in np.flatnonzero(dof > 0):
            ratio = ss[g, useful] / dof[g] / common[useful]
            raw[g] = float(np.median(ratio)) / (st.chi2.median(dof[g]) / dof[g])
        raw = np.clip(raw, 1e-3, 1e3)
        weight = np.where(dof > 0, dof / np.maximum(dof + nu0, 1e-300), 0.0)
        levels = np.exp(np.log(raw) * weight)
        levels /= np.exp(np.average(np.log(levels), weights=np.maximum(dof, 1e-9)))
    levels[dof == 0] = 1.0
    return levels


def _prior(cand: Candidate, knots: list[float]) -> tuple[float, float]:
    """Strength range of the prior: the library span extended by EXTEND, in the physical range."""
    lo, hi = min(knots), max(knots)
    if cand.name in LOG_SCALE:
        f = (hi / lo) ** EXTEND
        lo, hi = lo / f, hi * f
    else:
        span = hi - lo
        lo, hi = lo - EXTEND * span, hi + EXTEND * span
    if cand.kind == 'effect':
        lo = max(lo, cand.current)  # an effect that is off cannot be negative
    return max(lo, cand.low), min(hi, cand.high)


def _shrunk_cov(residuals: F64, n_models: int) -> F64:
    """Shrunk covariance of pooled residuals (dof corrected for the model means).

    The statistics have different units and scales (mm of displacement, N of draft), so the
    Ledoit-Wolf shrinkage acts on the correlation (residuals over their sd) and the sd are put
    back: each statistic keeps its own variance, the correlations are shrunk towards 0.
    """
    from sklearn.covariance import LedoitWolf

    n = len(residuals)
    scale = n / max(n - n_models, 1)
    sd = np.sqrt(np.mean(residuals**2, axis=0) * scale)
    sd = np.where(sd > 0, sd, 1e-12)
    fit = LedoitWolf(assume_centered=True).fit(residuals / sd)
    corr = np.asarray(fit.covariance_, np.float64)
    d = np.sqrt(np.diag(corr))
    corr = corr / np.outer(d, d)
    return corr * np.outer(sd, sd)
