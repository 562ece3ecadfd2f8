"""The recalibration objective: the diagnosis' likelihood, and the floor it is judged by.

The error of a model at strength x is the Mahalanobis distance d^2(x) of the measured group
statistics from the model's prediction under the diagnosis' covariance (seed + one-particle
sampling + measurement noise + model-discrepancy allowance, plus the emulator's own variance): the
likelihood of :mod:`~dempath_diagnose.decision.verdict`, not a new one. What the true model itself
gives over packing seeds is d^2 ~ chi^2_k (k observed statistics) only if the covariance is exactly
right: that nominal floor is its mean k and its band the central 95 % of chi^2_k. The diagnosis'
covariance carries a discrepancy allowance that dominates it, so a fitted model's d^2 lies far
below chi^2_k; the loop therefore stops on the *like-for-like* band when one is given
(``floor_band``: the model at the strengths played as the measurement by every library seed,
the same markers, samples, layout and covariance, :mod:`dempath_diagnose.headline.d2floor`),
and on the nominal mean k only when none can be computed (more than one strength fitted, or no
library runs of the candidate). No simulation runs here.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy import stats

from dempath_diagnose.decision.emulator import CandidateEmulator, Emulator
from dempath_diagnose.decision.verdict import gauss_logpdf
from dempath_diagnose.headline.floor import FloorBand
from dempath_diagnose.records import F64

BandOf = Callable[[tuple[float, ...]], FloorBand | None]  # strengths -> like-for-like d^2 band

SIGNIFICANT = 0.95  # chi^2 quantile above which an error is significantly above the floor


@dataclass(frozen=True)
class Floor:
    """What the true model gives over packing seeds, in d^2 units.

    Attributes:
        k: Number of observed statistics (the mean of chi^2_k).
        low, high: Central 95 % band of chi^2_k.
        significant: d^2 above this is significantly above the floor.
    """

    k: int
    low: float
    high: float
    significant: float

    @classmethod
    def of(cls, k: int) -> Floor:
        """The floor of k observed statistics."""
        return cls(k, float(stats.chi2.ppf(0.025, k)), float(stats.chi2.ppf(0.975, k)),
                   float(stats.chi2.ppf(SIGNIFICANT, k)))

    def above(self, d2: float) -> float:
        """The error above the floor (0 when at or below it)."""
        return max(0.0, d2 - self.k)


@dataclass(frozen=True)
class Objective:
    """d^2 of the measured statistics against a model prediction.

    Attributes:
        emulator: The diagnosis' emulator (baseline mean and candidate responses).
        y: (k_obs,) measured statistics.
        observed: (k,) which statistics were measured.
        cov: (k, k) fixed covariance of the diagnosis.
        floor_band: The like-for-like d^2 band of the model at given strengths (None: the
            loop stops at the nominal chi^2 mean).
    """

    emulator: Emulator
    y: F64
    observed: NDArray[np.bool_]
    cov: F64
    floor_band: BandOf | None = None

    @property
    def floor(self) -> Floor:
        """The floor of the observed statistics."""
        return Floor.of(int(self.observed.sum()))

    def d2(self, prediction: F64, extra_var: F64 | None = None) -> float:
        """d^2 of ``prediction`` (k,), with ``extra_var`` (k,) added to the diagonal."""
        obs = self.observed
        sub = self.cov[np.ix_(obs, obs)]
        if extra_var is not None:
            sub = sub + np.diag(extra_var[obs])
        r = self.y - prediction[obs]
        if not np.all(np.isfinite(r)):
            return float('inf')
        return gauss_logpdf(r, sub)[1]

    def baseline(self) -> float:
        """d^2 of the user's model as it is (the error before)."""
        return self.d2(self.emulator.mu0)

    def emulated(self, cand: CandidateEmulator, x: float) -> float:
        """d^2 of ``cand`` at strength ``x`` as the emulator predicts it."""
        diff, var = cand.predict(np.array([x], np.float64))
        return self.d2(self.emulator.mu0 + diff[0], var[0])

    def real(self, runs: F64, shift: F64 | None = None) -> float:
        """d^2 of simulated statistics ``runs`` (S, k), averaged over their packing seeds.

        ``shift`` (k,) is the baseline's seed mean minus the baseline on the same seeds (the
        paired correction: chaos of the few seeds cancels in the difference); the variance of
        the seed mean of the paired differences is added.
        """
        mean = runs.mean(0)
        extra = runs.var(0, ddof=1) / len(runs) if len(runs) > 1 else np.zeros(runs.shape[1])
        if shift is not None:
            mean = mean + shift
        return self.d2(mean, extra)
