"""The headline error: each measured trajectory scored against the model's distribution.

The bed is chaotic, so a measured marker is one draw from a distribution: the paths of the
grains that could have been that marker (the particles starting in its candidate cube, the
paper's Cube candidates) over packing seeds. A proper scoring rule judges a draw against a
distribution and is lowest, on average, for the distribution the draw came from (Gneiting &
Raftery 2007, JASA 102:359): a model that misses an effect scores worse than the true one, a
model that only spreads wider does not score better (unlike the best-N-of-the-cube nRMSE of the
paper's Table 7, which rewards a wider model). We use the energy score, the multivariate
continuous ranked probability score used to verify ensemble weather forecasts,

    ES(F, y) = E||X - y|| - 1/2 E||X - X'||,   X, X' ~ F independent,

with ``scoringrules`` (es_ensemble, the 'nrg' estimator) over the marker's displacement path
(every measured sample, three axes). A marker is scored only at the times it was measured, and
its model members at the same times. The score of a path of n samples grows like sqrt(n); the
headline divides by sqrt(n), so it reads in metres like an RMS distance, and averages over the
markers. A figure and its floor must share markers, samples and pool size
(:mod:`dempath_diagnose.headline.floor`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from dempath_diagnose.library.counterparts import cube_members
from dempath_diagnose.records import F64, Measurement, PassRecord

MIN_SAMPLES = 3  # a marker measured at fewer times is not scored
MIN_MEMBERS = 2  # an ensemble needs two members for its spread


@dataclass(frozen=True)
class HeadlineError:
    """The headline error of one model against one measurement.

    Attributes:
        value: Mean over the scored markers of the per-marker score [m].
        per_marker: (m,) score per marker [m] (NaN: not scored).
        markers: (m,) marker numbers.
        pools: Number of candidate pools averaged over.
        pool_seeds: Packing seeds per pool.
    """

    value: float
    per_marker: F64
    markers: tuple[int, ...]
    pools: int
    pool_seeds: int


def displacement_paths(rec: PassRecord, idx: Sequence[int], times: F64) -> F64:
    """(p, n, 3) paths of particles ``idx`` of ``rec`` at ``times``, from their position at
    ``times[0]`` [m] (linear interpolation of the run's frames)."""
    pos = np.asarray(rec.positions[:, list(idx)], np.float64)  # (nt, p, 3)
    out = np.empty((len(idx), len(times), 3))
    for a in range(3):
        for k in range(len(idx)):
            out[k, :, a] = np.interp(times, rec.times, pos[:, k, a], right=np.nan)
    return out - out[:, :1]


def marker_scores(meas: Measurement, pool: Sequence[PassRecord],
                  cube: tuple[float, float, float]) -> F64:
    """(m,) energy score per marker of ``meas`` against the cube candidates of ``pool`` [m].

    Each marker is scored at its measured samples only; the score is divided by sqrt(n), n the
    number of samples (see the module docstring).
    """
    import scoringrules as sr

    starts = meas.start
    members = [cube_members(rec.start, starts, cube) for rec in pool]
    out = np.full(len(meas.markers), np.nan)
    for j in range(len(meas.markers)):
        ok = np.isfinite(meas.positions[:, j]).all(1)
        if ok.sum() < MIN_SAMPLES:
            continue
        t = meas.times[ok]
        y = meas.positions[ok, j] - meas.positions[ok, j][0]
        ens = np.concatenate([displacement_paths(rec, m[j].tolist(), t)
                              for rec, m in zip(pool, members, strict=True)])
        ens = ens[np.isfinite(ens).all(axis=(1, 2))]
        if len(ens) < MIN_MEMBERS:
            continue
        score = sr.es_ensemble(y.ravel(), ens.reshape(len(ens), -1), backend='numpy')
        out[j] = float(score) / np.sqrt(len(t))
    return out


def headline_error(meas: Measurement, pools: Sequence[Sequence[PassRecord]],
                   cube: tuple[float, float, float]) -> HeadlineError:
    """The headline error of ``meas`` against each candidate pool, averaged over the pools.

    Args:
        meas: The measurement (NaN where a marker was not measured).
        pools: Candidate pools, each a model's runs on some packing seeds; all of one size
            (the floor uses pools of the same size, :mod:`.floor`).
        cube: Candidate cube size (X, Y, Z) [m].

    Raises:
        ValueError: No pool, pools of different sizes, or no marker could be scored.
    """
    sizes = {len(p) for p in pools}
    if len(sizes) != 1:
        raise ValueError(f'headline_error: pools of sizes {sorted(sizes)}; one size expected')
    per = np.nanmean([marker_scores(meas, p, cube) for p in pools], axis=0) \
        if all(len(p) for p in pools) else np.full(len(meas.markers), np.nan)
    if not np.isfinite(per).any():
        raise ValueError('headline_error: no marker could be scored')
    return HeadlineError(float(np.nanmean(per)), per, tuple(int(m) for m in meas.markers),
                         len(pools), sizes.pop())
