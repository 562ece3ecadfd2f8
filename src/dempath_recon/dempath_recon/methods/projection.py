# ruff: noqa: N806  (matrix notation of the references: K, R, P, X)
"""The OpenCV camera model in numpy: project world points (with the Jacobian), undistort pixels.

What triangulation (:mod:`dempath_recon.methods.triangulate`), its uncertainty and the tracker's
epipolar checks need of a camera: the :class:`Camera` protocol (K, dist, R, t: what
``dempath_calib.camera.CameraModel`` holds), the distorted projection ``u = fx xd + s yd + cx``,
``v = fy yd + cy`` with the k1 k2 p1 p2 k3 model, its analytic Jacobian with respect to the world
point, and the inverse (cv2.undistortPointsIter). Vectorised over points; NaN for points at or
behind the camera and for missing pixels.
"""

from __future__ import annotations

from typing import Protocol

import cv2
import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
UNDISTORT_ITERATIONS = 20  # fixed-point steps of cv2.undistortPointsIter (stops earlier at eps)
UNDISTORT_EPS = 1e-10  # its convergence threshold


class Camera(Protocol):
    """What triangulation needs from a camera (``dempath_calib.camera.CameraModel`` fits)."""

    width: int
    height: int
    K: FloatArray
    dist: FloatArray
    R: FloatArray
    t: FloatArray


def _distort(cam: Camera, xyz: FloatArray) -> tuple[FloatArray, ...]:
    """Shared steps of the projection: camera frame, normalised and distorted coordinates."""
    pc = np.asarray(xyz, dtype=np.float64) @ np.asarray(cam.R).T + np.asarray(cam.t)
    z = pc[:, 2]
    with np.errstate(divide='ignore', invalid='ignore'):
        x, y = pc[:, 0] / z, pc[:, 1] / z
    k1, k2, p1, p2, k3 = np.asarray(cam.dist, dtype=np.float64)
    r2 = x * x + y * y
    radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
    xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x)
    yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y
    return z, x, y, r2, radial, xd, yd


def project_points(cam: Camera, xyz: FloatArray) -> FloatArray:
    """Project world points with the OpenCV distortion model, vectorised in numpy.

    ``u = fx xd + s yd + cx``, ``v = fy yd + cy`` with ``xd = x (1 + k1 r^2 + k2 r^4 + k3 r^6)
    + 2 p1 x y + p2 (r^2 + 2 x^2)`` and likewise ``yd`` (OpenCV calib3d documentation).

    Args:
        cam: camera with K (3, 3) px, dist (5,) (k1 k2 p1 p2 k3), R (3, 3), t (3,) m.
        xyz: (n, 3) world points [m].

    Returns:
        (n, 2) distorted pixel coordinates [px]; NaN for points at or behind the camera.
    """
    z, _, _, _, _, xd, yd = _distort(cam, xyz)
    K = np.asarray(cam.K)
    uv = np.stack([K[0, 0] * xd + K[0, 1] * yd + K[0, 2], K[1, 1] * yd + K[1, 2]], axis=1)
    uv[~(z > 0)] = np.nan
    return uv


def project_with_jacobian(cam: Camera, xyz: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Projection and its analytic Jacobian with respect to the world point.

    Args:
        cam: the camera.
        xyz: (n, 3) world points [m].

    Returns:
        uv (n, 2) px and J = d uv / d xyz (n, 2, 3) px/m (NaN behind the camera).
    """
    z, x, y, r2, radial, xd, yd = _distort(cam, xyz)
    k1, k2, p1, p2, k3 = np.asarray(cam.dist, dtype=np.float64)
    dr = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2)  # d radial / d r^2
    d_dist = np.empty((len(z), 2, 2))  # d (xd, yd) / d (x, y)
    d_dist[:, 0, 0] = radial + 2.0 * x * x * dr + 2.0 * p1 * y + 6.0 * p2 * x
    d_dist[:, 0, 1] = 2.0 * x * y * dr + 2.0 * p1 * x + 2.0 * p2 * y
    d_dist[:, 1, 0] = 2.0 * x * y * dr + 2.0 * p1 * x + 2.0 * p2 * y
    d_dist[:, 1, 1] = radial + 2.0 * y * y * dr + 6.0 * p1 * y + 2.0 * p2 * x
    with np.errstate(divide='ignore', invalid='ignore'):
        inv_z = 1.0 / z
    d_norm = np.zeros((len(z), 2, 3))  # d (x, y) / d camera-frame point
    d_norm[:, 0, 0] = inv_z
    d_norm[:, 1, 1] = inv_z
    d_norm[:, 0, 2] = -x * inv_z
    d_norm[:, 1, 2] = -y * inv_z
    K = np.asarray(cam.K)
    jac = K[:2, :2] @ d_dist @ d_norm @ np.asarray(cam.R)
    uv = np.stack([K[0, 0] * xd + K[0, 1] * yd + K[0, 2], K[1, 1] * yd + K[1, 2]], axis=1)
    bad = ~(z > 0)
    uv[bad] = np.nan
    jac[bad] = np.nan
    return uv, jac


def undistort_normalized(cam: Camera, uv: FloatArray) -> FloatArray:
    """Distorted pixels (n, 2) px -> normalised image coordinates (n, 2) [-]; NaN stays NaN."""
    uv = np.asarray(uv, dtype=np.float64)
    out = np.full(uv.shape, np.nan)
    ok = np.isfinite(uv).all(axis=1)
    if ok.any():
        criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, UNDISTORT_ITERATIONS,
                    UNDISTORT_EPS)
        und = cv2.undistortPointsIter(uv[ok].reshape(-1, 1, 2), np.asarray(cam.K),
                                      np.asarray(cam.dist), None, None,  # type: ignore[call-overload]
                                      criteria)
        out[ok] = und.reshape(-1, 2)
    return out
