"""Compiled kernel: nearest-point distances of many experiment-model pairs at once.

For each pair it fills the DTW accumulated-cost matrix (squared Euclidean local cost, no window,
as dtaidistance ``dtw_ndim``), backtracks the warping path with dtaidistance's ``best_path`` rule
(at each step the smallest of diagonal, up, left; ties in that order) and keeps, for each
experimental point, the smallest weighted distance d = sqrt(dx^2 + dy^2 + w dz^2) among the model
points the path pairs with it (or among all model points). Pairs run in parallel (numba prange).
Tested against the plain per-pair path in :mod:`dempath_compare.metrics`.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange
from numpy.typing import NDArray


@njit(cache=True, inline='always')  # type: ignore[misc]
def _dist(a: NDArray[np.float64], b: NDArray[np.float64], w: float) -> float:
    dx, dy, dz = a[0] - b[0], a[1] - b[1], a[2] - b[2]
    return float(np.sqrt(dx * dx + dy * dy + w * dz * dz))


@njit(cache=True)  # type: ignore[misc]
def _pair(exp: NDArray[np.float64], mod: NDArray[np.float64], w: float, use_path: bool,
          best: NDArray[np.float64]) -> float:
    n, k = exp.shape[0], mod.shape[0]
    best[:n] = np.inf
    if not use_path:
        for i in range(n):
            for j in range(k):
                best[i] = min(best[i], _dist(exp[i], mod[j], w))
        return float(np.nan)
    acc = np.full((n + 1, k + 1), np.inf)
    acc[0, 0] = 0.0
    for i in range(1, n + 1):
        for j in range(1, k + 1):
            c = 0.0
            for a in range(3):
                diff = exp[i - 1, a] - mod[j - 1, a]
                c += diff * diff
            acc[i, j] = c + min(acc[i - 1, j - 1], acc[i - 1, j], acc[i, j - 1])
    i, j = n, k
    while i > 0 and j > 0:
        best[i - 1] = min(best[i - 1], _dist(exp[i - 1], mod[j - 1], w))
        diag, up, left = acc[i - 1, j - 1], acc[i - 1, j], acc[i, j - 1]
        if diag <= up and diag <= left:
            i, j = i - 1, j - 1
        elif up <= left:
            i -= 1
        else:
            j -= 1
    return float(np.sqrt(acc[n, k]))


@njit(cache=True, parallel=True)  # type: ignore[misc]
def pair_distances(exp: NDArray[np.float64], exp_len: NDArray[np.int64],
                   mod: NDArray[np.float64], mod_len: NDArray[np.int64],
                   pair_e: NDArray[np.int64], pair_m: NDArray[np.int64], w: float,
                   use_path: bool) -> tuple[NDArray[np.float64], NDArray[np.float64],
                                            NDArray[np.float64]]:
    """Scores of the pairs (pair_e[p], pair_m[p]).

    Args:
        exp: (n_e, T_e, 3) m padded experimental trajectories, exp_len (n_e,) valid samples.
        mod: (n_m, T_m, 3) m padded model trajectories, mod_len (n_m,) valid samples.
        pair_e, pair_m: (p,) indices of the pairs.
        w: Z weight of the distance.
        use_path: nearest point among DTW-paired points (True) or among all model points.

    Returns:
        (p,) S_sum [m], (p,) sum of d_i^2 [m^2], (p,) DTW distance [m] (NaN if not use_path).
    """
    n_pairs = pair_e.shape[0]
    sums = np.empty(n_pairs)
    squares = np.empty(n_pairs)
    dtw = np.empty(n_pairs)
    for p in prange(n_pairs):
        e, m = pair_e[p], pair_m[p]
        n = exp_len[e]
        best = np.empty(n)
        dtw[p] = _pair(exp[e, :n], mod[m, : mod_len[m]], w, use_path, best)
        sums[p] = best.sum()
        squares[p] = (best * best).sum()
    return sums, squares, dtw
