"""Compiled kernel: the cut-disc model's residual and Jacobian in one pass over a blob's pixels.

``cut_discs.fit_cut_discs`` hands MINPACK's Levenberg-Marquardt a residual and a Jacobian it
calls about twenty times a fit; a blob's fit evaluates them on a few hundred pixels for two or
three discs. In NumPy each call is some thirty small array operations (about 60 us of Python
overhead, more than the arithmetic), and on a grey bed with pale clay, where the detector tries
about four blobs a frame, the fits took half of the detection's time (8.7 ms of CPU a frame on
a seed-91 render, session 19). Here both come from one loop over the pixels (numba, cached on
disk). The model and its derivatives are those of :func:`~dempath_recon.tracking.cut_discs.
union_model` and :func:`~dempath_recon.tracking.cut_discs.union_jacobian`, which stay the
readable reference; the tests hold the two equal to rounding.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray


@njit(cache=True)  # type: ignore[misc]
def residual_and_jacobian(p: NDArray[np.float64], xy: NDArray[np.float64], k: int,
                          up: NDArray[np.float64], cut: bool, blur: float,
                          values: NDArray[np.float64], radius: float, spread: float,
                          res: NDArray[np.float64], jac: NDArray[np.float64]) -> None:
    """Fill ``res`` (n + 1,) and ``jac`` (n + 1, len(p)) for the parameters ``p`` (``A``,
    ``b``, ``r``, then ``x``, ``y`` and, when ``cut``, ``t`` per disc): the model at the
    pixels ``xy`` (n, 2) less ``values`` (n,), then the radius prior ``(r - radius) /
    spread``; ``up`` (2,) is the image's up direction (read only when ``cut``), ``blur`` the
    edges' blur ``s`` [px]."""
    scale = 1.0 / (math.sqrt(2.0) * blur)
    peak = 1.0 / (math.sqrt(2.0 * math.pi) * blur)
    n = xy.shape[0]
    per = 3 if cut else 2
    disc = np.empty(k)
    edge = np.empty(k)
    chord = np.empty(k)
    rim = np.empty(k)
    dx = np.empty(k)
    dy = np.empty(k)
    rho = np.empty(k)
    outside = np.empty(k)
    a, b, r = p[0], p[1], p[2]
    for i in range(n):
        covered = 1.0  # prod over the discs of (1 - f g): no marker covers the pixel
        for j in range(k):
            dx[j] = xy[i, 0] - p[3 + per * j]
            dy[j] = xy[i, 1] - p[4 + per * j]
            rho[j] = math.sqrt(dx[j] * dx[j] + dy[j] * dy[j]) + 1e-9
            t = (rho[j] - r) * scale
            disc[j] = 0.5 * math.erfc(t)
            edge[j] = math.exp(-t * t) * peak
            if cut:
                s = (dx[j] * up[0] + dy[j] * up[1] - p[5 + per * j]) * scale
                chord[j] = 0.5 * math.erfc(-s)
                rim[j] = math.exp(-s * s) * peak
            else:
                chord[j] = 1.0
                rim[j] = 0.0
            outside[j] = 1.0 - disc[j] * chord[j]
            covered *= outside[j]
        res[i] = b + a * (1.0 - covered) - values[i]
        for m in range(jac.shape[1]):
            jac[i, m] = 0.0
        jac[i, 0] = 1.0 - covered
        jac[i, 1] = 1.0
        for j in range(k):
            others = 1.0
            for m in range(k):
                if m != j:
                    others *= outside[m]
            gain = a * others
            jac[i, 2] += gain * edge[j] * chord[j]
            pull = gain * chord[j] * edge[j] / rho[j]
            jac[i, 3 + per * j] = pull * dx[j]
            jac[i, 4 + per * j] = pull * dy[j]
            if cut:
                jac[i, 3 + per * j] -= gain * disc[j] * rim[j] * up[0]
                jac[i, 4 + per * j] -= gain * disc[j] * rim[j] * up[1]
                jac[i, 5 + per * j] = -gain * disc[j] * rim[j]
    res[n] = (r - radius) / spread
    for m in range(jac.shape[1]):
        jac[n, m] = 0.0
    jac[n, 2] = 1.0 / spread


def warm() -> None:
    """Load the compiled kernel now rather than at the first touching pair (its cached load
    takes a few ms once numba is set up, :func:`~dempath_recon.tracking.centroid_kernel.warm`)."""
    res, jac = np.empty(2), np.empty((2, 5))
    residual_and_jacobian(np.zeros(5), np.zeros((1, 2)), 1, np.zeros(2), False, 0.6,
                          np.zeros(1), 1.0, 0.1, res, jac)
