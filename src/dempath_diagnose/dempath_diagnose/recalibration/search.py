"""The search of the recalibration: where the next real evaluation goes, and its uncertainty.

The strengths are searched on the diagnosis' emulator (cheap: an interpolation per candidate),
corrected by the bias the real evaluations showed, never on the real runs directly (each costs a
simulation). Several candidates (the effect and the parameters refitted beside it, ``--also``)
act additively: mu0 + sum_i diff_i(x_i), variances added (the library measured each alone, on
paired seeds).

- One strength: a bounded scalar search (scipy ``minimize_scalar``, ``bounded``), log axis for
  the LOG_SCALE parameters.
- Several: CMA-ES (``cma``, Hansen's reference implementation; the optimiser ACCES runs over
  whole DEM simulations) on the unit box of the candidates' prior ranges, with a fixed seed so
  that a rerun proposes the same strengths.

The uncertainty of several strengths is the Laplace approximation at the optimum: the
covariance of the strengths is the inverse of half the Hessian of d^2 (d^2 = -2 log L + c).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.optimize import minimize_scalar

from dempath_diagnose.decision.emulator import CandidateEmulator
from dempath_diagnose.recalibration.objective import Objective
from dempath_diagnose.records import F64
from dempath_sim.effects.candidates import LOG_SCALE

CMA_SIGMA0 = 0.3  # initial step of CMA-ES on the unit box (a third of each prior range)
CMA_MAX_EVALS = 1500  # emulator evaluations CMA-ES may use (milliseconds each)
CMA_SEED = 14  # fixed: the same data propose the same strengths
HESSIAN_STEP = 1e-3  # finite-difference step on the unit box for the Laplace covariance


def _is_log(cand: CandidateEmulator) -> bool:
    return cand.candidate.name in LOG_SCALE


def to_unit(cands: Sequence[CandidateEmulator], x: F64) -> F64:
    """Strengths (n,) -> the unit box of the prior ranges (log axis for LOG_SCALE)."""
    out = []
    for c, v in zip(cands, x, strict=True):
        lo, hi = c.prior
        if _is_log(c):
            lo, hi, v = np.log(lo), np.log(hi), np.log(max(v, 1e-300))
        out.append((v - lo) / (hi - lo) if hi > lo else 0.5)
    return np.array(out, np.float64)


def from_unit(cands: Sequence[CandidateEmulator], u: F64) -> F64:
    """The unit box -> strengths (n,), clipped into the prior ranges."""
    out = []
    for c, w in zip(cands, np.clip(u, 0.0, 1.0), strict=True):
        lo, hi = c.prior
        if _is_log(c):
            out.append(float(np.exp(np.log(lo) + w * (np.log(hi) - np.log(lo)))))
        else:
            out.append(float(lo + w * (hi - lo)))
    return np.array(out, np.float64)


def emulated_d2(objective: Objective, cands: Sequence[CandidateEmulator], x: F64,
                bias: F64 | None = None) -> float:
    """d^2 the emulator predicts at strengths ``x`` (plus the observed ``bias`` (k,))."""
    pred = objective.emulator.mu0.copy()
    var = np.zeros_like(pred)
    for c, v in zip(cands, x, strict=True):
        d, dv = c.predict(np.array([v], np.float64))
        pred += d[0]
        var += dv[0]
    if bias is not None:
        pred = pred + bias
    return objective.d2(pred, var)


def propose(objective: Objective, cands: Sequence[CandidateEmulator],
            bias: F64 | None = None, x0: F64 | None = None) -> F64:
    """The strengths minimising the (bias-corrected) emulated d^2 in the prior ranges."""
    if len(cands) == 1:
        (c,) = cands
        lo, hi = c.prior
        log = _is_log(c)

        def f(u: float) -> float:
            return emulated_d2(objective, cands, np.array([np.exp(u) if log else u]), bias)

        a, b = (np.log(lo), np.log(hi)) if log else (lo, hi)
        res = minimize_scalar(f, bounds=(a, b), method='bounded',
                              options={'xatol': 1e-3 * (b - a)})
        return np.array([np.exp(res.x) if log else res.x], np.float64)
    import cma

    start = to_unit(cands, x0) if x0 is not None else np.full(len(cands), 0.5)
    opts = {'bounds': [0.0, 1.0], 'seed': CMA_SEED, 'maxfevals': CMA_MAX_EVALS,
            'verbose': -9, 'tolfun': 1e-6}
    best, _ = cma.fmin2(lambda u: emulated_d2(objective, cands, from_unit(cands, u), bias),
                        np.clip(start, 0.05, 0.95), CMA_SIGMA0, opts)
    return from_unit(cands, np.asarray(best, np.float64))


def laplace_sd(objective: Objective, cands: Sequence[CandidateEmulator], x: F64,
               bias: F64 | None = None) -> F64:
    """(n,) sd of the strengths at ``x`` from the Hessian of d^2 (NaN where it is flat)."""
    n = len(cands)
    u0 = to_unit(cands, x)
    h = HESSIAN_STEP

    def f(u: F64) -> float:
        return emulated_d2(objective, cands, from_unit(cands, u), bias)

    hess = np.zeros((n, n))
    for i in range(n):
        for j in range(n):
            e_i, e_j = np.eye(n)[i] * h, np.eye(n)[j] * h
            hess[i, j] = (f(u0 + e_i + e_j) - f(u0 + e_i - e_j) - f(u0 - e_i + e_j)
                          + f(u0 - e_i - e_j)) / (4 * h * h)
    try:
        cov_u = np.linalg.inv(hess / 2.0)
    except np.linalg.LinAlgError:
        return np.full(n, np.nan)
    sd_u = np.sqrt(np.clip(np.diag(cov_u), 0.0, None))
    sd_u = np.where(np.diag(cov_u) > 0, sd_u, np.nan)
    out = []
    for c, v, s in zip(cands, x, sd_u, strict=True):
        lo, hi = c.prior
        out.append(v * s * (np.log(hi) - np.log(lo)) if _is_log(c) else s * (hi - lo))
    return np.array(out, np.float64)
