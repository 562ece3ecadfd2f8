"""The paper's scores for one experiment-model pair, written plainly (the reference path).

Kuře & Kuřetová 2025 (Technologies 13, 570), sec. 2.5:

- DTW (eq. 2): dtaidistance ``dtw_ndim`` with its defaults: squared Euclidean local cost in 3D,
  no window, standard boundary / continuity / monotonicity; the returned value is
  sqrt(min over paths of the summed squared distances) [m].
- nearest-point distance (eq. 3): d_i = sqrt(dx^2 + dy^2 + w dz^2) from experimental point i to its
  nearest corresponding model point (see :class:`~dempath_compare.config.Matching`).
- S_sum = sum_i d_i and S_mean = (1/N) sum_i d_i = MAE (eq. 4); RMSE = sqrt((1/N) sum_i d_i^2)
  (eq. 5), N = number of experimental points.
- nRMSE = RMSE / range * 100 [%] (Table 7), range of the measured trajectory.

:mod:`dempath_compare.scoring` computes the same numbers for many pairs at once; a test checks
that both agree.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from dempath_compare.config import CompareConfig, Matching, RangeKind


class PairScore(NamedTuple):
    """Scores of one experiment-model pair; distances in m, nRMSE in %."""

    dtw: float
    s_sum: float
    s_mean: float
    rmse: float
    n_points: int


def weighted_distances(exp: NDArray[np.float64], model: NDArray[np.float64],
                       z_weight: float) -> NDArray[np.float64]:
    """(n, m) m: d(i, j) = sqrt(dx^2 + dy^2 + w dz^2) of exp (n, 3) and model (m, 3) points."""
    diff = exp[:, None, :] - model[None, :, :]
    weights = np.array([1.0, 1.0, z_weight])
    return np.asarray(np.sqrt(np.sum(weights * diff * diff, axis=2)))


def dtw_path(exp: NDArray[np.float64],
             model: NDArray[np.float64]) -> tuple[float, list[tuple[int, int]]]:
    """DTW distance [m] and warping path [(i_exp, j_model), ...] from dtaidistance ``dtw_ndim``."""
    from dtaidistance import dtw_ndim

    path, distance = dtw_ndim.warping_path(exp, model, include_distance=True)
    return float(distance), [(int(i), int(j)) for i, j in path]


def nearest_distances(exp: NDArray[np.float64], model: NDArray[np.float64], z_weight: float,
                      path: list[tuple[int, int]] | None = None) -> NDArray[np.float64]:
    """(n,) m: d_i of each experimental point to its nearest corresponding model point.

    Args:
        exp: (n, 3) m experimental trajectory.
        model: (m, 3) m model trajectory.
        z_weight: w of eq. 3.
        path: DTW warping path; when given, the nearest point is searched among the model points
            the path pairs with point i, else among all model points.
    """
    dist = weighted_distances(exp, model, z_weight)
    if path is None:
        return np.asarray(dist.min(axis=1))
    best = np.full(len(exp), np.inf)
    for i, j in path:
        best[i] = min(best[i], dist[i, j])
    return best


def s_sum(d: NDArray[np.float64]) -> float:
    """Total deviation score S_sum = sum d_i [m] (eq. 4)."""
    return float(np.sum(d))


def s_mean(d: NDArray[np.float64]) -> float:
    """Average deviation score S_mean = MAE = mean d_i [m] (eq. 4)."""
    return float(np.mean(d))


def rmse(d: NDArray[np.float64]) -> float:
    """RMSE = sqrt(mean d_i^2) [m] (eq. 5)."""
    return float(np.sqrt(np.mean(d * d)))


def trajectory_range(positions: NDArray[np.float64], kind: RangeKind | str) -> float:
    """Range of a trajectory (k, 3) m: bounding-box diagonal (extent) or path length [m]."""
    if RangeKind(kind) is RangeKind.LENGTH:
        return float(np.sum(np.linalg.norm(np.diff(positions, axis=0), axis=1)))
    return float(np.linalg.norm(np.max(positions, axis=0) - np.min(positions, axis=0)))


def nrmse(rmse_m: float, range_m: float) -> float:
    """nRMSE = RMSE / range * 100 [%]; NaN for a zero range."""
    return float(rmse_m / range_m * 100.0) if range_m > 0.0 else float('nan')


def score_pair(exp: NDArray[np.float64], model: NDArray[np.float64],
               config: CompareConfig) -> PairScore:
    """All scores of one pair, one formula after the other (the slow, obvious path)."""
    distance, path = dtw_path(exp, model)
    use_path = path if config.matching is Matching.DTW else None
    d = nearest_distances(exp, model, config.z_weight, use_path)
    return PairScore(distance, s_sum(d), s_mean(d), rmse(d), len(d))
