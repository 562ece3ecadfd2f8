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
  shrunk with Ledoit-Wolf (few seeds, many statistics);
- the sampling covariance of one particle per cube (mean over the runs);
- measurement noise ``noise_m`` per axis over the markers of the group;
- the model-discrepancy allowance: ``discrepancy_m + discrepancy_rel * |mu0|`` for the marker
  statistics and ``discrepancy_force_rel * |mu0|`` for the draft, as an independent sd.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from dempath_diagnose.decision.statistics import Layout, model_statistics
from dempath_diagnose.library.simulator import Candidate
from dempath_diagnose.library.store import Library
from dempath_diagnose.records import F64
from dempath_sim.effects.candidates import LOG_SCALE

EXTEND = 0.25  # the prior range reaches this fraction of the library's span beyond it


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
    """

    candidate: Candidate
    knots: F64
    diffs: F64
    diff_var: F64
    prior: tuple[float, float]

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
    residuals = [b - mu0]
    emulators = []
    for cand in library.candidates:
        runs = library.model_runs(cand.name)
        knots, diffs, dvar = [0.0], [np.zeros(len(mu0))], [np.zeros(len(mu0))]
        for x, files in sorted(runs.items()):
            c = np.array([stats[f].vector for f in files])
            d = c - b[:len(c)]
            knots.append(x)
            diffs.append(d.mean(0))
            dvar.append(d.var(0, ddof=1) / len(d) if len(d) > 1 else np.abs(d.mean(0)) ** 2)
            residuals.append(c - c.mean(0))
        knots[0] = cand.current
        order = np.argsort(knots)
        emu = CandidateEmulator(cand, np.zeros(0), np.array(diffs)[order],
                                np.array(dvar)[order], _prior(cand, knots))
        emu = CandidateEmulator(cand, emu.transform(np.array(knots)[order]), emu.diffs,
                                emu.diff_var, emu.prior)
        emulators.append(emu)
    seed_cov = _shrunk_cov(np.concatenate(residuals), len(library.candidates) + 1)
    sampling = np.mean([s.sampling_cov for s in stats.values()], axis=0)
    feats = np.array([stats[f].features for f in base_files])
    fvar = np.nanmean([stats[f].feature_var for f in base_files], axis=0)
    return Emulator(layout.names(True), mu0, seed_cov, sampling, emulators, b, feats, fvar)


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
