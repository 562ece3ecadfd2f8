# ruff: noqa: N806  (matrix notation of the references: K, R, P, X)
"""Camera resection from a calibration point set: known 3D points and their pixels in each view.

The paper trained its network on 94,939 pixel/point pairs; the same pairs calibrate both cameras
directly, which lets the classical methods be fitted on exactly the MLP's training data.

Method: normalised linear DLT for the 3x4 projection matrix (Hartley & Zisserman, *Multiple View
Geometry*, 2nd ed., alg. 7.1), RQ decomposition into K, R, t (``cv2.decomposeProjectionMatrix``),
then Levenberg-Marquardt over intrinsics, distortion (k1 k2 p1 p2 k3) and pose with
``cv2.calibrateCamera`` started from that guess (non-planar targets need the guess).
"""

from __future__ import annotations

import logging

import cv2
import numpy as np
from numpy.typing import NDArray

from dempath_calib.camera import CameraModel
from dempath_recon.errors import ReconstructionError

FloatArray = NDArray[np.float64]
logger = logging.getLogger(__name__)

MIN_POINTS = 12  # well above the 6 a DLT needs, so that distortion is constrained too
MAX_POINTS = 20000  # resection subsample: more adds time, not accuracy
CAMERA_NAMES = ('cam_side', 'cam_front')


def _normalising_transform(pts: FloatArray) -> FloatArray:
    """Similarity moving points to zero mean and RMS distance sqrt(dim) (Hartley normalisation)."""
    dim = pts.shape[1]
    mean = pts.mean(axis=0)
    scale = np.sqrt(dim) / np.sqrt(((pts - mean) ** 2).sum(axis=1).mean())
    T = np.eye(dim + 1)
    T[:dim, :dim] *= scale
    T[:dim, dim] = -scale * mean
    return T


def resect_linear(xyz: FloatArray, uv: FloatArray) -> FloatArray:
    """Normalised linear DLT for the projection matrix.

    Args:
        xyz: (n, 3) world points [m], n >= 6.
        uv: (n, 2) pixels [px].

    Returns:
        (3, 4) projection matrix P with ``uv ~ P [xyz; 1]``.
    """
    T3, T2 = _normalising_transform(xyz), _normalising_transform(uv)
    X = np.c_[xyz, np.ones(len(xyz))] @ T3.T
    x = np.c_[uv, np.ones(len(uv))] @ T2.T
    zeros = np.zeros_like(X)
    rows_u = np.hstack([X, zeros, -x[:, :1] * X])
    rows_v = np.hstack([zeros, X, -x[:, 1:2] * X])
    _, _, vt = np.linalg.svd(np.vstack([rows_u, rows_v]), full_matrices=False)
    P = vt[-1].reshape(3, 4)
    return np.asarray(np.linalg.inv(T2) @ P @ T3, dtype=np.float64)


def resect_camera(xyz: FloatArray, uv: FloatArray, image_size: tuple[int, int],
                  name: str = 'camera', seed: int = 0) -> CameraModel:
    """Calibrate one camera (K, distortion, pose) from 3D-2D correspondences.

    Args:
        xyz: (n, 3) world points [m].
        uv: (n, 2) pixels [px]; rows with NaN are ignored.
        image_size: (width, height) [px].
        name: camera name for the returned model.
        seed: seed of the subsample drawn when n > MAX_POINTS.

    Returns:
        The resected ``CameraModel``.

    Raises:
        ReconstructionError: too few finite correspondences.
    """
    ok = np.isfinite(uv).all(axis=1) & np.isfinite(xyz).all(axis=1)
    if ok.sum() < MIN_POINTS:
        msg = f'{name}: resection needs at least {MIN_POINTS} finite points, got {ok.sum()}'
        raise ReconstructionError(msg)
    idx = np.flatnonzero(ok)
    if len(idx) > MAX_POINTS:
        idx = np.random.default_rng(seed).choice(idx, MAX_POINTS, replace=False)
    obj, img = xyz[idx].astype(np.float32), uv[idx].astype(np.float32)
    P = resect_linear(xyz[idx], uv[idx])
    P *= np.sign(np.linalg.det(P[:, :3]))  # points in front of the camera
    K, R, c = cv2.decomposeProjectionMatrix(P)[:3]
    flip = np.diag(np.sign(np.diag(K)))  # RQ sign freedom: make the focal lengths positive
    K, R = K @ flip / (K[2, 2] * flip[2, 2]), flip @ R
    K[0, 1] = 0.0  # OpenCV's model has no skew
    t = -R @ (c[:3, 0] / c[3, 0])
    flags = cv2.CALIB_USE_INTRINSIC_GUESS | cv2.CALIB_USE_EXTRINSIC_GUESS
    rms, K, dist, rvecs, tvecs = cv2.calibrateCamera(
        [obj], [img], image_size, K, np.zeros(5), [cv2.Rodrigues(R)[0]], [t.reshape(3, 1)],
        flags=flags)
    logger.info('%s: resected from %d points, RMS reprojection %.3f px', name, len(idx), rms)
    R = cv2.Rodrigues(rvecs[0])[0]
    f64 = np.float64
    return CameraModel(name, image_size[0], image_size[1], np.asarray(K, f64),
                       np.asarray(dist, f64).ravel()[:5], np.asarray(R, f64),
                       np.asarray(tvecs[0], f64).ravel())


def resect_stereo(pixels: FloatArray, xyz: FloatArray,
                  image_size: tuple[int, int] = (1920, 1080)) -> tuple[CameraModel, CameraModel]:
    """Both cameras from a point set in the paper's layout.

    Args:
        pixels: (n, 4) px = (xs, ys, xf, yf).
        xyz: (n, 3) world points [m].
        image_size: (width, height) [px] of both cameras.

    Returns:
        (side, front) ``CameraModel`` pair.
    """
    pixels, xyz = np.asarray(pixels, float), np.asarray(xyz, float)
    if pixels.ndim != 2 or pixels.shape[1] != 4 or xyz.shape != (len(pixels), 3):
        msg = f'point set: expected pixels (n, 4) and xyz (n, 3), got {pixels.shape}, {xyz.shape}'
        raise ReconstructionError(msg)
    side = resect_camera(xyz, pixels[:, 0:2], image_size, CAMERA_NAMES[0])
    front = resect_camera(xyz, pixels[:, 2:4], image_size, CAMERA_NAMES[1])
    return side, front
