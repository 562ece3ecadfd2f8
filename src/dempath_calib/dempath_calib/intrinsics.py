"""Per-camera intrinsics from board views (Zhang's method via cv2.calibrateCamera), with checks.

Views are fixed-shape corner arrays ``(n_views, n_corners, 2) px`` with NaN for unseen corners.
Before solving, the views are screened: too few usable views or an image with uncovered parts
gives :class:`NotEnoughViewsError` naming how many more are needed and where; views that all show
the same pose give :class:`DegenerateViewsError`.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from enum import Enum

import cv2
import numpy as np
from numpy.typing import NDArray

from dempath_calib.board import BoardSpec
from dempath_calib.errors import CalibrationError, DegenerateViewsError, NotEnoughViewsError

LOG = logging.getLogger(__name__)
FloatArray = NDArray[np.float64]
CELL_NAMES = (('top-left', 'top', 'top-right'), ('left', 'centre', 'right'),
              ('bottom-left', 'bottom', 'bottom-right'))
MIN_POSE_SPREAD_PX = 3.0  # views whose common corners all move less than this are one pose
MIN_TILT_SPREAD_DEG = 5.0  # board orientations must differ by at least this much
MAX_ITER = 100  # Levenberg-Marquardt iterations of cv2.calibrateCamera
OUTLIER_FACTOR = 3.0  # a view whose RMSE exceeds this many times the median is dropped...
OUTLIER_FLOOR_PX = 0.5  # ...if its RMSE is also above this [px] (grazing or blurred views)


class DistortionModel(Enum):
    """Which of OpenCV's k1, k2, p1, p2, k3 are estimated (the others are held at zero)."""

    NONE = 'none'
    K1 = 'k1'
    K1K2 = 'k1k2'
    K1K2K3 = 'k1k2k3'
    K1K2P1P2 = 'k1k2p1p2'
    FULL = 'k1k2p1p2k3'

    @property
    def free(self) -> NDArray[np.bool_]:
        """(5,) mask of estimated coefficients in OpenCV order k1 k2 p1 p2 k3."""
        v = self.value
        return np.array(['k1' in v, 'k2' in v, 'p1' in v, 'p2' in v, 'k3' in v])

    @property
    def cv_flags(self) -> int:
        """Flags for cv2.calibrateCamera."""
        free = self.free
        flags = 0
        for on, flag in ((free[0], cv2.CALIB_FIX_K1), (free[1], cv2.CALIB_FIX_K2),
                         (free[4], cv2.CALIB_FIX_K3)):
            flags |= 0 if on else flag
        return flags | (0 if free[2] else cv2.CALIB_ZERO_TANGENT_DIST)


@dataclass(frozen=True)
class IntrinsicResult:
    """Result of one camera's intrinsic calibration.

    Attributes:
        K: (3, 3) camera matrix [px].
        dist: (5,) k1 k2 p1 p2 k3.
        rmse_px: overall reprojection RMSE [px].
        view_rmse_px: (n_used,) RMSE of each used view [px].
        views: (n_used,) indices of the used views.
        rvecs: (n_used, 3) board->camera rotation vectors.
        tvecs: (n_used, 3) board->camera translations [m].
    """

    K: FloatArray
    dist: FloatArray
    rmse_px: float
    view_rmse_px: FloatArray
    views: NDArray[np.int64]
    rvecs: FloatArray
    tvecs: FloatArray


def usable_views(corners: FloatArray, board: BoardSpec, min_corners: int) -> NDArray[np.bool_]:
    """(n_views,) mask of views with >= ``min_corners`` corners spanning 2 rows and 2 columns."""
    found = ~np.isnan(corners[..., 0])
    nx = board.columns - 1
    ids = np.arange(board.n_corners)
    ok = found.sum(1) >= min_corners
    for i in np.flatnonzero(ok):
        cols, rows = ids[found[i]] % nx, ids[found[i]] // nx
        ok[i] = len(np.unique(cols)) >= 2 and len(np.unique(rows)) >= 2
    return np.asarray(ok, bool)


def coverage(corners: FloatArray, size: tuple[int, int]) -> NDArray[np.int64]:
    """(3, 3) number of detected corners in each ninth of the image (rows top to bottom)."""
    pts = corners.reshape(-1, 2)
    pts = pts[~np.isnan(pts[:, 0])]
    w, h = size
    cx = np.clip((pts[:, 0] * 3 // w).astype(int), 0, 2)
    cy = np.clip((pts[:, 1] * 3 // h).astype(int), 0, 2)
    counts = np.zeros((3, 3), np.int64)
    np.add.at(counts, (cy, cx), 1)
    return counts


def check_views(name: str, corners: FloatArray, board: BoardSpec, size: tuple[int, int],
                min_views: int, min_corners: int) -> NDArray[np.bool_]:
    """Screen views before calibrating; returns the usable-view mask.

    Raises:
        NotEnoughViewsError: fewer than ``min_views`` usable views (says how many more and
            which parts of the image have no corners).
        DegenerateViewsError: every usable view shows the board in the same pose.
    """
    ok = usable_views(corners, board, min_corners)
    n = int(ok.sum())
    if n < min_views:
        empty = [CELL_NAMES[r][c] for r, c in zip(*np.nonzero(coverage(corners[ok], size) == 0),
                                                   strict=True)]
        where = f'; no corners yet in the {", ".join(empty)} of the image' if empty else ''
        msg = (f'{name}: {n} usable board views (>= {min_corners} corners), need {min_views}: '
               f'{min_views - n} more{where}')
        raise NotEnoughViewsError(msg)
    used = corners[ok]
    ref = used[0]
    moved = [np.nanmax(np.linalg.norm(v - ref, axis=1), initial=0.0) for v in used[1:]]
    if max(moved, default=0.0) < MIN_POSE_SPREAD_PX:
        msg = (f'{name}: all {n} views show the board in the same pose (corners move less than '
               f'{MIN_POSE_SPREAD_PX} px); move and tilt the board between views')
        raise DegenerateViewsError(msg)
    return ok


def calibrate_intrinsics(name: str, corners: FloatArray, board: BoardSpec,
                         size: tuple[int, int], model: DistortionModel = DistortionModel.FULL,
                         min_views: int = 8, min_corners: int = 6) -> IntrinsicResult:
    """Calibrate one camera from its board views.

    Args:
        name: camera name (for messages).
        corners: (n_views, n_corners, 2) px, NaN where unseen.
        board: the target.
        size: (width, height) of the images [px].
        model: which distortion coefficients to estimate.
        min_views: least number of usable views.
        min_corners: least corners for a view to be used.

    Raises:
        NotEnoughViewsError, DegenerateViewsError, CalibrationError.
    """
    ok = check_views(name, corners, board, size, min_views, min_corners)
    views = np.flatnonzero(ok)
    obj_all = board.object_points().astype(np.float32)
    obj, img = [], []
    for i in views:
        seen = ~np.isnan(corners[i, :, 0])
        obj.append(obj_all[seen])
        img.append(corners[i, seen].astype(np.float32))
    k0 = np.array([[size[0], 0, size[0] / 2], [0, size[0], size[1] / 2], [0, 0, 1.0]])
    result = _solve(name, obj, img, views, size, k0, model)
    bad = result.view_rmse_px > max(OUTLIER_FACTOR * np.median(result.view_rmse_px),
                                    OUTLIER_FLOOR_PX)
    if bad.any() and (~bad).sum() >= min_views:
        LOG.info('%s: dropping %d outlier views (RMSE > %.2f px): %s', name, int(bad.sum()),
                 OUTLIER_FACTOR * np.median(result.view_rmse_px), views[bad].tolist())
        keep = np.flatnonzero(~bad)
        result = _solve(name, [obj[i] for i in keep], [img[i] for i in keep], views[keep],
                        size, result.K, model)
    _check_tilt_spread(name, result.rvecs)
    LOG.info('%s: intrinsics from %d views, RMSE %.3f px', name, len(result.views),
             result.rmse_px)
    return result


def _solve(name: str, obj: list[NDArray[np.float32]], img: list[NDArray[np.float32]],
           views: NDArray[np.int64], size: tuple[int, int], k0: FloatArray,
           model: DistortionModel) -> IntrinsicResult:
    criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, MAX_ITER, 1e-10)
    try:
        rms, k, dist, rvecs, tvecs = cv2.calibrateCamera(
            obj, img, size, k0.copy(), np.zeros(5), flags=model.cv_flags, criteria=criteria)
    except cv2.error as err:
        msg = f'{name}: OpenCV calibration failed on {len(views)} views ({err})'
        raise CalibrationError(msg) from err
    per_view = np.array([
        np.sqrt(np.mean(np.sum((cv2.projectPoints(o, r, t, k, dist)[0].reshape(-1, 2)
                                - i.reshape(-1, 2)) ** 2, axis=1)))
        for o, i, r, t in zip(obj, img, rvecs, tvecs, strict=True)])
    return IntrinsicResult(np.asarray(k, np.float64), np.asarray(dist, np.float64).ravel()[:5],
                           float(rms), per_view, views.astype(np.int64),
                           np.array(rvecs, np.float64).reshape(-1, 3),
                           np.array(tvecs, np.float64).reshape(-1, 3))


def _check_tilt_spread(name: str, rvecs: FloatArray) -> None:
    """Refuse a calibration whose board normals all point the same way (focal length unknown)."""
    normals = np.array([cv2.Rodrigues(r)[0][:, 2] for r in rvecs])
    cosines = np.clip(normals @ normals.T, -1, 1)
    spread = float(np.degrees(np.arccos(cosines.min())))
    if spread < MIN_TILT_SPREAD_DEG:
        msg = (f'{name}: board orientations differ by only {spread:.1f} deg over {len(rvecs)} '
               f'views (need {MIN_TILT_SPREAD_DEG}); tilt the board between views')
        raise DegenerateViewsError(msg)
