"""The image model of touching markers the detector splits: a union of known-size discs, each
optionally cut by the sand in front of it, fitted to a blob's chroma.

Both markers of a touching pair are the same clay, and the chroma ``(B - R) / (B + G + R)`` is
the same everywhere on a marker (shading cancels), so the chroma of touching markers is the
*union* of their visible parts at one level, not the sum of two bumps. A marker sunk in the heap
shows only its upper part: seen from a low camera (the tuning re-renders' views at 29-31
degrees), the sand in front hides a segment of its image disc below a chord across the image's
up direction (:mod:`~dempath_recon.tracking.covered`). The model of a blob of ``k`` markers is

    c(x) = b + A * (1 - prod_i (1 - f_i(x) g_i(x)))
    f_i(x) = 1/2 erfc((|x - x_i| - r) / (sqrt(2) s))            (the disc)
    g_i(x) = 1/2 erfc(-((x - x_i) . u - t_i) / (sqrt(2) s))      (above the sand's chord)

with the disc radius ``r`` the calibration and the markers' depth give (held near it by a prior
residual), an edge blurred by ``s`` (JPEG's half-resolution chroma and the optics), ``u`` the
image direction of world up, and ``t_i`` the chord's height above the disc's centre along ``u``
(``-r`` or lower: the whole disc seen). Without ``u`` the discs are whole (``g_i = 1``). The
disc centre ``x_i`` is the marker's centre, whatever share of it the sand leaves: the fit reads
it from the seen rim's arc, where a whole-disc fit put a covered marker's disc on its visible
part, 3-3.5 px off (session 16, track7).

Fitted by Levenberg-Marquardt (MINPACK's ``lmder``, as ``scipy.optimize.leastsq`` calls it,
without that wrapper's checks) with the analytic Jacobian; residual and Jacobian come from one
compiled pass over the pixels (:mod:`~dempath_recon.tracking.cut_discs_kernel`), which
``union_model`` and ``union_jacobian`` here state readably and the tests hold it to.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numpy.typing import NDArray
from scipy.optimize._minpack import _lmder  # MINPACK itself (scipy pinned: constraints)
from scipy.special import erfc

from dempath_recon.tracking.cut_discs_kernel import residual_and_jacobian

FloatArray = NDArray[np.float64]
EDGE_BLUR = 0.6  # edge blur s of the model [detector px] (JPEG chroma at half resolution)
RADIUS_SPREAD = 0.1  # the prior's standard deviation of the radius, as a share of it
SQRT2 = float(np.sqrt(2.0))
Parts = tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]


@dataclass(frozen=True)
class BlobFit:
    """A blob's fitted markers.

    Attributes:
        centres: (k, 2) disc centres [detector px, window coordinates].
        cuts: (k,) each chord's height above its disc's centre along the up direction, as a
            share of the radius (-1 or less: the whole disc seen; all -1 without cuts).
        radius: the fitted disc radius [detector px].
        level: the markers' chroma above the sand's [-].
        cost: the fit's squared residual.
    """

    centres: FloatArray
    cuts: FloatArray
    radius: float
    level: float
    cost: float

    def seen(self, xy: FloatArray, up: FloatArray | None) -> NDArray[np.bool_]:
        """(n, k) which of the points ``xy`` (n, 2) each marker's seen part covers."""
        diff = xy[:, None, :] - self.centres[None]
        inside = np.linalg.norm(diff, axis=2) <= self.radius
        if up is None:
            return np.asarray(inside, np.bool_)
        return np.asarray(inside & (diff @ up >= self.cuts[None] * self.radius), np.bool_)


def pixel_grid(shape: tuple[int, ...], origin: tuple[int, int]) -> FloatArray:
    """(h * w, 2) the pixel centres of a patch of ``shape`` (h, w) at ``origin`` (x0, y0)."""
    h, w = shape[:2]
    if origin == (0, 0):
        return _patch_grid(h, w)
    yy, xx = np.mgrid[0:h, 0:w]
    return np.column_stack([xx.ravel() + origin[0], yy.ravel() + origin[1]]).astype(np.float64)


@lru_cache(maxsize=256)
def _patch_grid(h: int, w: int) -> FloatArray:
    """(h * w, 2) the pixel centres of an (h, w) patch in its own coordinates, read-only (a
    blob's fit asks for one of a few dozen shapes, several times a frame)."""
    yy, xx = np.mgrid[0:h, 0:w]
    grid = np.column_stack([xx.ravel(), yy.ravel()]).astype(np.float64)
    grid.flags.writeable = False
    return grid


def low_decile(values: FloatArray) -> float:
    """The 10th percentile of ``values`` (n,), n >= 1, exactly as ``np.percentile(values,
    10)`` gives it (linear between the order statistics at ``(n - 1) / 10``), from a
    partition of the two neighbours: ``np.percentile``'s general path cost a fit 20 % of its
    time (session 21)."""
    n = len(values)
    at = (n - 1) * 0.1
    i = int(np.floor(at))
    if i + 1 >= n:
        return float(np.max(values))
    part = np.partition(values, (i, i + 1))
    a, b = float(part[i]), float(part[i + 1])
    gap, t = b - a, at - i
    return b - gap * (1 - t) if t >= 0.5 else a + gap * t


def _parts(p: FloatArray, xy: FloatArray, k: int, up: FloatArray | None,
           ) -> Parts:
    """For parameters ``p`` (A, b, r, then x, y[, t] per disc): the offsets (n, k, 2), their
    lengths (n, k), each disc's membership f (n, k) and its radius derivative (n, k), each
    chord's membership g (n, k) and its derivative along ``u`` (n, k)."""
    per = 2 if up is None else 3
    q = p[3:].reshape(k, per)
    diff = xy[:, None, :] - q[None, :, :2]
    rho = np.sqrt((diff ** 2).sum(2)) + 1e-9
    t = (rho - p[2]) / (SQRT2 * EDGE_BLUR)
    disc = 0.5 * erfc(t)
    edge = np.exp(-t * t) / (np.sqrt(2.0 * np.pi) * EDGE_BLUR)  # d disc / d radius
    if up is None:
        ones = np.ones_like(disc)
        return diff, rho, disc, edge, ones, np.zeros_like(disc)
    s = (diff @ up - q[None, :, 2]) / (SQRT2 * EDGE_BLUR)
    chord = 0.5 * erfc(-s)
    rim = np.exp(-s * s) / (np.sqrt(2.0 * np.pi) * EDGE_BLUR)  # d chord / d (x . u)
    return diff, rho, disc, edge, chord, rim


def union_model(p: FloatArray, xy: FloatArray, k: int, up: FloatArray | None,
                parts: Parts | None = None) -> FloatArray:
    """(n,) the model's chroma at the points ``xy`` (n, 2) for the parameters ``p``: ``A``,
    ``b``, ``r``, then per marker ``x``, ``y`` (and ``t`` with ``up``) [detector px]
    (``parts``: ``_parts`` of the same, if already computed)."""
    disc, chord = (parts or _parts(p, xy, k, up))[2::2]
    return np.asarray(p[1] + p[0] * (1.0 - np.prod(1.0 - disc * chord, axis=1)), np.float64)


def union_jacobian(p: FloatArray, xy: FloatArray, k: int, up: FloatArray | None,
                   parts: Parts | None = None) -> FloatArray:
    """(n, len(p)) the derivatives of ``union_model`` by each parameter (analytic: the model is
    ``b + A (1 - prod (1 - f_i g_i))``, so d/d(f_i g_i) is ``A`` times the other markers'
    ``prod (1 - f_j g_j)``; f_i moves with its centre and the radius, g_i with its centre and
    its chord)."""
    per = 2 if up is None else 3
    diff, rho, disc, edge, chord, rim = parts or _parts(p, xy, k, up)
    outside = 1.0 - disc * chord
    # (n, k): no other marker covers the pixel
    others = outside[:, ::-1] if k == 2 else np.ones_like(outside) if k == 1 else np.stack(
        [np.prod(np.delete(outside, i, axis=1), axis=1) for i in range(k)], axis=1)
    jac = np.zeros((len(xy), 3 + per * k))
    jac[:, 0] = 1.0 - np.prod(outside, axis=1)
    jac[:, 1] = 1.0
    jac[:, 2] = p[0] * (others * edge * chord).sum(1)
    gain = p[0] * others  # (n, k): d model / d (f_i g_i)
    pull = gain * chord * edge / rho
    jac[:, 3::per] = pull * diff[:, :, 0]
    jac[:, 4::per] = pull * diff[:, :, 1]
    if up is not None:
        jac[:, 3::per] -= gain * disc * rim * up[0]
        jac[:, 4::per] -= gain * disc * rim * up[1]
        jac[:, 5::per] = -gain * disc * rim
    return jac


def fit_cut_discs(patch: NDArray[np.float32], origin: tuple[int, int], start: FloatArray,
                  radius: float, up: FloatArray | None = None) -> BlobFit:
    """Least-squares fit of ``len(start)`` touching discs, cut by the sand when ``up`` is
    given, to a chroma ``patch``.

    The radius is held near the expected one by a prior residual (``RADIUS_SPREAD``), so a
    disc cannot grow over two markers.

    Args:
        patch: (h, w) chroma around the blob.
        origin: (x0, y0) of the patch in window coordinates [detector px].
        start: (k, 2) initial centres [detector px, window coordinates].
        radius: expected disc radius [detector px].
        up: (2,) the image direction of world up (a unit vector), or None: whole discs.
    """
    # fitted in the patch's own pixel coordinates and moved to ``origin`` after: MINPACK's
    # stopping test is relative to the size of the parameters, so centres at window coordinates
    # of hundreds of pixels stopped far coarser than near zero, and one spot's fit depended on
    # where its window began (the windowed and the whole-frame detector up to 0.97 px apart on
    # real renders, session 19)
    shift = np.asarray(origin, np.float64)
    xy = pixel_grid(patch.shape, (0, 0))
    values = patch.ravel().astype(np.float64)
    k, per = len(start), (2 if up is None else 3)
    low, high = low_decile(values), float(values.max())
    level = max(high - low, 1e-3)
    spread = RADIUS_SPREAD * radius / level  # the prior's weight against a pixel's residual

    n, m = len(values), 3 + per * k
    res, jac = np.empty(n + 1), np.empty((n + 1, m))
    at = [b'']  # the parameters' bytes res and jac were last filled for
    direction = np.zeros(2) if up is None else np.asarray(up, np.float64)

    def fill(p: FloatArray) -> None:  # MINPACK asks the Jacobian where it asked the residual
        key = p.tobytes()  # the same bytes: the same parameters (a few us under array_equal)
        if key != at[0]:
            residual_and_jacobian(p, xy, k, direction, up is not None, EDGE_BLUR, values,
                                  radius, spread, res, jac)
            at[0] = key

    def residual(p: FloatArray) -> FloatArray:
        fill(p)
        return res.copy()

    def jacobian(p: FloatArray) -> FloatArray:
        fill(p)
        return jac.copy()

    local = np.asarray(start, np.float64) - shift
    first = local if up is None else np.column_stack([local, np.full(k, -radius)])
    p0 = np.concatenate([[level, low, radius], first.ravel()])
    # MINPACK's lmder as least_squares(method='lm', x_scale='jac') calls it (scipy 1.16), called
    # directly: scipy's leastsq wrapper adds a residual and a Jacobian call to check shapes and
    # a covariance nobody reads, half the time of a fit beside the compiled kernel (session 21)
    x, _ = _lmder(residual, jacobian, p0, (), 0, 0, 1e-4, 1e-4, 1e-8,
                  20 * (k + 1) * (per - 1), 100.0, None)
    fill(x)  # the residual at the solution (MINPACK's own fvec: the same kernel, the same x)
    fvec = res
    q = x[3:].reshape(k, per)
    r = float(x[2])
    cuts = np.full(k, -1.0) if up is None else np.maximum(q[:, 2] / max(r, 1e-6), -1.0)
    return BlobFit(np.asarray(q[:, :2] + shift, np.float64), np.asarray(cuts, np.float64), r,
                   float(x[0]), float(np.dot(fvec, fvec)))
