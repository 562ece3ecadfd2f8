# ruff: noqa: N803, N806  (matrix notation of the references: K, R, P, X)
"""Classical two-camera reconstruction: undistort, linear triangulation, nonlinear refinement.

Every function is vectorised over points (numpy, no Python loop per point). Array contract, as in
aniposelib: pixels of the views ``(n_cams, n, 2) px`` -> points ``(n, 3) m`` in the world frame
(X lateral, Y up, Z travel), NaN where fewer than two finite views exist.

Method (Hartley & Zisserman, *Multiple View Geometry*, 2nd ed., sec. 12.2 and 4.1):

1. Undistort each view to normalised image coordinates ``(x, y)`` (OpenCV model k1 k2 p1 p2 k3;
   the camera model, its projection and Jacobian are :mod:`dempath_recon.methods.projection`).
2. Linear (DLT) triangulation, inhomogeneous form: for each view and world point ``X``,
   ``(x r3 - r1) . X = t1 - x t3`` and ``(y r3 - r2) . X = t2 - y t3`` with ``R = [r1; r2; r3]``;
   the stacked rows are solved by least squares, then re-weighted by the estimated depth
   ``1 / (r3 . X + t3)`` so that the residual approximates the image-plane error.
3. Optional Gauss-Newton refinement of the reprojection error in distorted pixels (the maximum
   likelihood estimate for Gaussian pixel noise), whose normal matrix also gives the first-order
   covariance used by :mod:`dempath_recon.methods.uncertainty`.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from dempath_recon.errors import NotFittedError, PixelInputError, ReconstructionError
from dempath_recon.methods.projection import (
    Camera,
    FloatArray,
    project_points,
    project_with_jacobian,
    undistort_normalized,
)

logger = logging.getLogger(__name__)


class Triangulation(NamedTuple):
    """Result of :func:`triangulate_points`.

    Attributes:
        xyz: (n, 3) world points [m]; NaN with fewer than 2 finite views.
        reprojection_error: (n,) mean reprojection error over the used views [px].
        n_views: (n,) number of finite views used per point.
    """

    xyz: FloatArray
    reprojection_error: FloatArray
    n_views: NDArray[np.int64]


def split_views(pixels: FloatArray) -> FloatArray:
    """Paper layout ``(n, 4) px = (xs, ys, xf, yf)`` -> views ``(2, n, 2) px`` (side, front)."""
    arr = np.asarray(pixels, dtype=np.float64)
    if arr.ndim != 2 or arr.shape[1] != 4:
        msg = f'pixels: expected shape (n, 4) = (xs, ys, xf, yf), got {arr.shape}'
        raise PixelInputError(msg)
    return np.stack([arr[:, 0:2], arr[:, 2:4]])


def _linear_system(cams: Sequence[Camera], xn: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Rows of the inhomogeneous DLT: M (n, 2*n_cams, 3), b (n, 2*n_cams); NaN views -> 0."""
    rows, rhs = [], []
    for cam, v in zip(cams, xn, strict=True):
        R, t = np.asarray(cam.R), np.asarray(cam.t)
        ok = np.isfinite(v).all(axis=1)
        x = np.where(ok, v[:, 0], 0.0)[:, None]
        y = np.where(ok, v[:, 1], 0.0)[:, None]
        w = ok[:, None].astype(np.float64)
        rows += [w * (x * R[2] - R[0]), w * (y * R[2] - R[1])]
        rhs += [w[:, 0] * (t[0] - x[:, 0] * t[2]), w[:, 0] * (t[1] - y[:, 0] * t[2])]
    return np.stack(rows, axis=1), np.stack(rhs, axis=1)


def triangulate_linear(cams: Sequence[Camera], xn: FloatArray, reweight: int = 1) -> FloatArray:
    """Linear triangulation of normalised coordinates with depth re-weighting.

    Args:
        cams: the cameras (poses are used; intrinsics were removed by undistortion).
        xn: (n_cams, n, 2) normalised image coordinates [-], NaN for a missing view.
        reweight: number of depth re-weighting passes after the first solve.

    Returns:
        (n, 3) world points [m]; NaN where fewer than two views are finite.
    """
    M, b = _linear_system(cams, xn)
    n_views = np.isfinite(xn).all(axis=2).sum(axis=0)
    good = n_views >= 2
    xyz = np.full((xn.shape[1], 3), np.nan)
    if not good.any():
        return xyz
    M, b = M[good], b[good]
    weights = np.ones(b.shape)
    for _ in range(reweight + 1):
        Mw, bw = M * weights[:, :, None], b * weights
        A = np.matmul(Mw.transpose(0, 2, 1), Mw)
        rhs = np.einsum('nki,nk->ni', Mw, bw)
        sol = solve3(A, rhs)
        depth = np.stack([sol @ np.asarray(c.R)[2] + np.asarray(c.t)[2] for c in cams], axis=1)
        weights = np.repeat(1.0 / np.maximum(np.abs(depth), 1e-9), 2, axis=1)
    xyz[good] = sol
    return xyz


def projection_jacobian(cams: Sequence[Camera], xyz: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Projections into every camera and their Jacobians with respect to the world point.

    Args:
        cams: the cameras.
        xyz: (n, 3) world points [m].

    Returns:
        uv (n_cams, n, 2) px and J (n_cams, n, 2, 3) px/m.
    """
    pairs = [project_with_jacobian(c, xyz) for c in cams]
    return np.stack([p[0] for p in pairs]), np.stack([p[1] for p in pairs])


def solve3(A: FloatArray, b: FloatArray) -> FloatArray:
    """Solve many 3x3 systems ``A x = b`` by the adjugate (fast for millions of points).

    Args:
        A: (n, 3, 3) matrices.
        b: (n, 3) right-hand sides.

    Returns:
        (n, 3) solutions; NaN for singular matrices.
    """
    c0 = np.cross(A[:, 1], A[:, 2])
    c1 = np.cross(A[:, 2], A[:, 0])
    c2 = np.cross(A[:, 0], A[:, 1])
    det = np.einsum('ni,ni->n', A[:, 0], c0)
    adj = np.stack([c0, c1, c2], axis=2)  # inverse = adj / det
    with np.errstate(divide='ignore', invalid='ignore'):
        return np.asarray(np.einsum('nij,nj->ni', adj, b) / det[:, None], dtype=np.float64)


def refine_points(cams: Sequence[Camera], views: FloatArray, xyz: FloatArray,
                  iterations: int = 2) -> FloatArray:
    """Gauss-Newton refinement of the reprojection error in distorted pixels.

    Args:
        cams: the cameras.
        views: (n_cams, n, 2) observed pixels [px], NaN for a missing view.
        xyz: (n, 3) initial world points [m] (NaN rows are left NaN).
        iterations: Gauss-Newton steps.

    Returns:
        (n, 3) refined world points [m].
    """
    xyz = xyz.copy()
    ok = np.isfinite(xyz).all(axis=1)
    seen: NDArray[np.bool_] = np.all(np.isfinite(views), axis=2)[:, ok]
    obs = np.where(seen[..., None], views[:, ok], 0.0)
    x = xyz[ok]
    for _ in range(iterations):
        uv, jac = projection_jacobian(cams, x)
        res = np.where(seen[..., None], uv - obs, 0.0)
        jac = np.where(seen[..., None, None], jac, 0.0)
        jac = np.nan_to_num(jac)
        A = np.einsum('cnki,cnkj->nij', jac, jac)
        g = np.einsum('cnki,cnk->ni', jac, np.nan_to_num(res))
        step = solve3(A, g)
        x = x - np.nan_to_num(step)
    xyz[ok] = x
    return xyz


def reprojection_errors(cams: Sequence[Camera], views: FloatArray, xyz: FloatArray) -> FloatArray:
    """Mean over the finite views of the pixel distance between observation and projection.

    Args:
        cams: the cameras.
        views: (n_cams, n, 2) observed pixels [px].
        xyz: (n, 3) world points [m].

    Returns:
        (n,) mean reprojection error [px]; NaN where the point or all views are NaN.
    """
    uv = np.stack([project_points(c, xyz) for c in cams])
    dist = np.linalg.norm(uv - views, axis=2)
    valid = np.isfinite(dist)
    count = valid.sum(axis=0)
    total = np.where(valid, dist, 0.0).sum(axis=0)
    return np.where(count > 0, total / np.maximum(count, 1), np.nan)


def triangulate_points(cams: Sequence[Camera], views: FloatArray, refine: bool = True,
                       with_errors: bool = True) -> Triangulation:
    """Undistort, triangulate linearly and (optionally) refine; the one-call classical method.

    Args:
        cams: the calibrated cameras (at least two).
        views: (n_cams, n, 2) distorted pixels [px], NaN for a missing view.
        refine: run the Gauss-Newton refinement of the pixel reprojection error.
        with_errors: compute the reprojection errors (else they are NaN; saves time).

    Returns:
        The :class:`Triangulation` (xyz (n, 3) m, reprojection_error (n,) px, n_views (n,)).
    """
    views = np.asarray(views, dtype=np.float64)
    if views.ndim != 3 or views.shape[0] != len(cams) or views.shape[2] != 2:
        msg = f'views: expected shape ({len(cams)}, n, 2) px, got {views.shape}'
        raise PixelInputError(msg)
    if len(cams) < 2:
        msg = f'cameras: triangulation needs at least 2, got {len(cams)}'
        raise ReconstructionError(msg)
    xn = np.stack([undistort_normalized(c, v) for c, v in zip(cams, views, strict=True)])
    xyz = triangulate_linear(cams, xn)
    if refine:
        xyz = refine_points(cams, views, xyz)
    n_views = np.isfinite(views).all(axis=2).sum(axis=0).astype(np.int64)
    err = reprojection_errors(cams, views, xyz) if with_errors else np.full(len(xyz), np.nan)
    return Triangulation(xyz, err, n_views)


class DLTTriangulator:
    """Classical reconstruction behind the estimator surface shared with the MLP.

    ``fit`` takes the calibration (a ``StereoCalibration`` or a sequence of cameras); when only
    a point set is given, the cameras are resected from it
    (:mod:`dempath_recon.methods.resection`).

    Args:
        refine: run the Gauss-Newton refinement after the linear solve.
    """

    name = 'dlt'

    def __init__(self, refine: bool = True) -> None:
        self.refine = refine

    def fit(self, X: FloatArray | None = None, y: FloatArray | None = None, *,
            calibration: Any = None) -> DLTTriangulator:
        """Take the cameras from ``calibration``, or resect them from pixels X and points y.

        Args:
            X: (n, 4) calibration pixels [px] (xs, ys, xf, yf), used without a calibration.
            y: (n, 3) calibration points [m].
            calibration: ``StereoCalibration`` (``.cameras``) or a sequence of cameras.

        Returns:
            self, with ``cameras_`` and ``n_features_in_`` set.
        """
        if calibration is not None:
            cams = getattr(calibration, 'cameras', calibration)
            self.cameras_ = tuple(cams)
        elif X is not None and y is not None:
            from dempath_recon.methods.resection import resect_stereo
            self.cameras_ = resect_stereo(np.asarray(X, float), np.asarray(y, float))
        else:
            msg = 'fit: give a calibration, or pixels X (n, 4) and points y (n, 3)'
            raise ReconstructionError(msg)
        self.n_features_in_ = 2 * len(self.cameras_)
        return self

    def _cams(self) -> tuple[Camera, ...]:
        if not hasattr(self, 'cameras_'):
            msg = f'{type(self).__name__}: not fitted; call fit(calibration=...) first'
            raise NotFittedError(msg)
        return self.cameras_

    def triangulate(self, pixels: FloatArray) -> Triangulation:
        """Full result (xyz, reprojection error, views) for pixels (n, 4) px."""
        return triangulate_points(self._cams(), split_views(pixels), refine=self.refine)

    def predict(self, pixels: FloatArray) -> FloatArray:
        """Pixels (n, 4) px (xs, ys, xf, yf) -> world points (n, 3) m."""
        return triangulate_points(self._cams(), split_views(pixels), refine=self.refine,
                                  with_errors=False).xyz


# The camera model the functions above take is part of this module's surface (the tracker imports
# it from here); it lives in :mod:`dempath_recon.methods.projection`.
__all__ = [
    'Camera',
    'DLTTriangulator',
    'Triangulation',
    'project_points',
    'project_with_jacobian',
    'projection_jacobian',
    'refine_points',
    'reprojection_errors',
    'solve3',
    'split_views',
    'triangulate_linear',
    'triangulate_points',
    'undistort_normalized',
]
