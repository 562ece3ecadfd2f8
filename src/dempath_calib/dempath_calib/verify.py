"""Checks of a calibration: corner spacing in 3D (the paper's test), errors against a known truth.

The paper checked its calibration by the distance between neighbouring board corners
reconstructed in 3D: 40.43 mm for 40.4 mm squares, 95% interval 38.38-42.42 mm (Technologies
2025, 13, 570). ``neighbour_distances`` repeats that with linear triangulation of the undistorted
corners; ``compare_to_truth`` measures a calibration against the twin's true cameras.
"""

from __future__ import annotations

from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from dempath_calib.board import BoardSpec
from dempath_calib.camera import CameraModel, StereoCalibration

FloatArray = NDArray[np.float64]


def triangulate(calib: StereoCalibration, uv_side: FloatArray, uv_front: FloatArray) -> FloatArray:
    """Linear (DLT) triangulation of distorted pixel pairs.

    Args:
        calib: the two cameras.
        uv_side: (n, 2) px in the side camera.
        uv_front: (n, 2) px in the front camera.

    Returns:
        (n, 3) world points [m] (NaN where an input is NaN).
    """
    out = np.full((len(uv_side), 3), np.nan)
    ok = np.isfinite(uv_side).all(1) & np.isfinite(uv_front).all(1)
    if not ok.any():
        return out
    ns = calib.side.undistort_points(uv_side[ok], normalized=True)
    nf = calib.front.undistort_points(uv_front[ok], normalized=True)
    ps = np.hstack([calib.side.R, calib.side.t[:, None]])
    pf = np.hstack([calib.front.R, calib.front.t[:, None]])
    hom = cv2.triangulatePoints(ps, pf, ns.T, nf.T)
    out[ok] = (hom[:3] / hom[3]).T
    return out


def neighbour_distances(calib: StereoCalibration, corners: FloatArray,
                        board: BoardSpec) -> FloatArray:
    """Distances between reconstructed neighbouring corners seen by both cameras.

    Args:
        calib: the two cameras.
        corners: (n_frames, 2, n_corners, 2) px, NaN where unseen.
        board: the target (its neighbour pairs are one square apart).

    Returns:
        (m,) distances [m] over every frame and every neighbouring pair seen by both cameras.
    """
    n, _, k, _ = corners.shape
    xyz = triangulate(calib, corners[:, 0].reshape(-1, 2), corners[:, 1].reshape(-1, 2))
    xyz = xyz.reshape(n, k, 3)
    pairs = board.neighbour_pairs()
    d = np.linalg.norm(xyz[:, pairs[:, 0]] - xyz[:, pairs[:, 1]], axis=2).ravel()
    return np.asarray(d[np.isfinite(d)], np.float64)


def distance_summary(d: FloatArray, true_m: float) -> dict[str, float]:
    """Mean, SD, 95% interval (mean +- 1.96 SD), mean and RMS error of distances, in mm."""
    mm = d * 1e3
    mean, sd = float(mm.mean()), float(mm.std(ddof=1)) if len(mm) > 1 else 0.0
    err = mm - true_m * 1e3
    return {'n': len(mm), 'true_mm': true_m * 1e3, 'mean_mm': mean, 'sd_mm': sd,
            'ci95_low_mm': mean - 1.96 * sd, 'ci95_high_mm': mean + 1.96 * sd,
            'mean_error_mm': float(err.mean()), 'rms_error_mm': float(np.sqrt(np.mean(err ** 2)))}


def rotation_angle_deg(r_a: FloatArray, r_b: FloatArray) -> float:
    """Angle of the rotation between two rotation matrices [deg]."""
    c = (np.trace(r_a @ r_b.T) - 1) / 2
    return float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))


def relative_pose(a: CameraModel, b: CameraModel) -> tuple[FloatArray, FloatArray]:
    """Pose of camera b relative to camera a: ``x_b = R x_a + t`` (R (3, 3), t (3,) m)."""
    r = b.R @ a.R.T
    return r, b.t - r @ a.t


def camera_errors(est: CameraModel, true: CameraModel) -> dict[str, Any]:
    """Intrinsic and pose errors of one camera against the truth."""
    k, kt = est.K, true.K
    return {'fx_rel_pct': 100 * (k[0, 0] - kt[0, 0]) / kt[0, 0],
            'fy_rel_pct': 100 * (k[1, 1] - kt[1, 1]) / kt[1, 1],
            'cx_px': k[0, 2] - kt[0, 2], 'cy_px': k[1, 2] - kt[1, 2],
            'dist': (est.dist - true.dist).tolist(),
            'rotation_deg': rotation_angle_deg(est.R, true.R),
            'center_mm': float(1e3 * np.linalg.norm(est.center - true.center))}


def max_distortion_shift_px(est: CameraModel, true: CameraModel, step: int = 40) -> float:
    """Largest difference over the image between the two lens models' pixel positions [px]."""
    u, v = np.meshgrid(np.arange(0, true.width, step), np.arange(0, true.height, step))
    uv = np.column_stack([u.ravel(), v.ravel()]).astype(np.float64)
    rays = true.undistort_points(uv, normalized=True)
    pts = np.column_stack([rays, np.ones(len(rays))])
    a, _ = cv2.projectPoints(pts, np.zeros(3), np.zeros(3), est.K, est.dist)
    return float(np.max(np.linalg.norm(a.reshape(-1, 2) - uv, axis=1)))


def compare_to_truth(est: StereoCalibration, true: StereoCalibration) -> dict[str, Any]:
    """Errors of both cameras and of their relative pose against the truth."""
    r_e, t_e = relative_pose(est.side, est.front)
    r_t, t_t = relative_pose(true.side, true.front)
    return {'side': camera_errors(est.side, true.side),
            'front': camera_errors(est.front, true.front),
            'relative_rotation_deg': rotation_angle_deg(r_e, r_t),
            'baseline_mm': float(1e3 * np.linalg.norm(t_e)),
            'baseline_error_mm': float(1e3 * (np.linalg.norm(t_e) - np.linalg.norm(t_t)))}
