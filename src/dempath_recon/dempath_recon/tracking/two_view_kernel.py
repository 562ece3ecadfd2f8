"""Compiled kernel: the depth-reweighted linear triangulation of pairs of normalised points.

The tracking rules triangulate a frame's pairs of the two cameras several times a frame, a
handful of pairs each time (``associate.triangulate_pairs``). In NumPy each call was a dozen
small array operations on (k, 4, 3) stacks, about 0.3 ms whatever ``k``: a twentieth of the
tracker's time per image (session 24). Here one loop per pair builds the same four rows of the
inhomogeneous DLT (each view's ``u r3 - r1``, ``v r3 - r2`` against ``t1 - u t3``, ``t2 - v t3``),
weights them by the inverse depth of the previous solve (first all ones), and solves the 3 x 3
normal equations by LAPACK as ``np.linalg.solve`` does, with the sums in the same order, so the
points equal the NumPy version's (tested).
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray

SINGULAR_DET = 1e-300  # a normal matrix with |det| at most this has no solution (NaN)


@njit(cache=True)  # type: ignore[misc]
def two_view_linear(rot_a: NDArray[np.float64], t_a: NDArray[np.float64],
                    rot_b: NDArray[np.float64], t_b: NDArray[np.float64],
                    xa: NDArray[np.float64], xb: NDArray[np.float64],
                    reweight: int) -> NDArray[np.float64]:
    """(k, 3) m: world points of the normalised pairs ``xa``, ``xb`` (k, 2) of two cameras
    (rotations (3, 3), translations (3,)), after ``reweight`` depth re-weightings; NaN where
    the normal matrix is singular."""
    k = xa.shape[0]
    out = np.full((k, 3), np.nan)
    m = np.empty((4, 3))
    b = np.empty(4)
    a = np.empty((3, 3))
    rhs = np.empty((3, 1))
    for i in range(k):
        for view in range(2):
            rot = rot_a if view == 0 else rot_b
            t = t_a if view == 0 else t_b
            u = xa[i, 0] if view == 0 else xb[i, 0]
            v = xa[i, 1] if view == 0 else xb[i, 1]
            for c in range(3):
                m[2 * view, c] = u * rot[2, c] - rot[0, c]
                m[2 * view + 1, c] = v * rot[2, c] - rot[1, c]
            b[2 * view] = t[0] - u * t[2]
            b[2 * view + 1] = t[1] - v * t[2]
        w = np.ones(4)
        sol = np.full(3, np.nan)
        for _ in range(reweight + 1):
            for r in range(3):
                for c in range(3):
                    s = 0.0
                    for j in range(4):
                        s += (m[j, r] * w[j]) * (m[j, c] * w[j])
                    a[r, c] = s
                s = 0.0
                for j in range(4):
                    s += (m[j, r] * w[j]) * (b[j] * w[j])
                rhs[r, 0] = s
            if abs(np.linalg.det(a)) > SINGULAR_DET:
                x = np.linalg.solve(a, rhs)
                for c in range(3):
                    sol[c] = x[c, 0]
            else:
                sol[:] = np.nan
            depth_a = sol[0] * rot_a[2, 0] + sol[1] * rot_a[2, 1] + sol[2] * rot_a[2, 2] + t_a[2]
            depth_b = sol[0] * rot_b[2, 0] + sol[1] * rot_b[2, 1] + sol[2] * rot_b[2, 2] + t_b[2]
            w[0] = w[1] = 1.0 / max(abs(depth_a), 1e-9)
            w[2] = w[3] = 1.0 / max(abs(depth_b), 1e-9)
        out[i] = sol
    return out
