"""Compiled kernel: the detector's iterated weighted centroids, one loop over each spot's window.

``MarkerDetector._refine`` moves a circular window of radius ``R`` onto each peak's centroid
of the chroma above the spot's core level ``base`` (Crocker and Grier 1996, section IV):

    w(x) = max(c(x) - base, 0) for |x - x_k| <= R, else 0
    x_{k+1} = sum w(x) x / sum w(x)

from the peak's pixel, at most ``iterations`` times or until a step is under ``tol`` [px]
(|dx| + |dy|); the window's pixels are those of the peak's rounded centre, the chroma read at
the nearest pixel inside the window (edge mode, as ``np.pad(mode='edge')``). It returns the
centre, the radius of gyration ``sqrt(sum w |x - x_k|^2 / sum w)`` and the mass ``sum w`` of
the last window. In NumPy each step was a dozen small array operations (about 25 us); on a
frame of 20-30 spots they took 0.4-0.9 ms (session 21). The sums run in order, not pairwise as
NumPy's, so centres agree with the NumPy version to about 1e-13 px (tested).

Reference: J. C. Crocker, D. G. Grier, "Methods of digital video microscopy for colloidal
studies", J. Colloid Interface Sci. 179 (1996) 298-310.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray


@njit(cache=True)  # type: ignore[misc]
def refine_centroids(c: NDArray[np.float32], rows: NDArray[np.intp], cols: NDArray[np.intp],
                     radius: float, half: int, base: float, iterations: int, tol: float,
                     out: NDArray[np.float64], size: NDArray[np.float64],
                     mass: NDArray[np.float64]) -> None:
    """Fill ``out`` (n, 2) with each peak's (``rows``, ``cols`` (n,) in ``c`` (h, w)) centre
    [px] (NaN where the window holds no chroma above ``base`` or the centre leaves ``c``),
    ``size`` (n,) with its radius of gyration [px] and ``mass`` (n,) with its window's
    weight (0 where NaN); the window's pixels lie within ``radius`` of the centre, in the
    (2 ``half`` + 1)^2 pixels around its rounded position."""
    h, w = c.shape
    r2 = radius * radius
    for k in range(rows.shape[0]):
        cx, cy = float(cols[k]), float(rows[k])
        ix, iy, fx, fy, total = 0, 0, 0.0, 0.0, 0.0
        for _ in range(iterations):
            ix = min(max(int(np.rint(cx)), 0), w - 1)
            iy = min(max(int(np.rint(cy)), 0), h - 1)
            fx, fy = cx - ix, cy - iy
            total, sx, sy = 0.0, 0.0, 0.0
            for a in range(-half, half + 1):
                dy = a - fy
                yr = min(max(iy + a, 0), h - 1)
                for b in range(-half, half + 1):
                    dx = b - fx
                    if dx * dx + dy * dy <= r2:
                        v = float(c[yr, min(max(ix + b, 0), w - 1)]) - base
                        if v > 0.0:
                            total += v
                            sx += v * b
                            sy += v * a
            if total <= 0.0:
                break
            nx, ny = ix + sx / total, iy + sy / total
            moved = abs(nx - cx) + abs(ny - cy)
            cx, cy = nx, ny
            if moved < tol:
                break
        if 0.0 <= cx < w and 0.0 <= cy < h and total > 0.0:
            out[k, 0], out[k, 1] = cx, cy
            # the last window (its pixels chosen about the centre before its step) about the
            # new centre
            gx, gy = cx - ix, cy - iy
            spread = 0.0
            for a in range(-half, half + 1):
                yr = min(max(iy + a, 0), h - 1)
                for b in range(-half, half + 1):
                    if (b - fx) * (b - fx) + (a - fy) * (a - fy) <= r2:
                        v = float(c[yr, min(max(ix + b, 0), w - 1)]) - base
                        if v > 0.0:
                            spread += v * ((b - gx) * (b - gx) + (a - gy) * (a - gy))
            size[k] = math.sqrt(spread / total)
            mass[k] = total
        else:
            out[k, 0], out[k, 1] = math.nan, math.nan
            size[k] = 0.0
            mass[k] = 0.0


def warm() -> None:
    """Load the compiled kernel now (numba's first call in a process sets up its typing,
    0.2-0.35 s of CPU, session 21): a detector node pays it when it starts, not on its first
    frame (at 50 frames/s, 10-17 frames late)."""
    out, size, mass = np.zeros((1, 2)), np.zeros(1), np.zeros(1)
    refine_centroids(np.zeros((3, 3), np.float32), np.ones(1, np.intp), np.ones(1, np.intp),
                     1.0, 1, 0.0, 1, 0.01, out, size, mass)
