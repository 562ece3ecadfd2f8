"""Clock offset between two cameras from the board's motion alone (no relative pose needed).

Each camera sees the board move; its pose in each frame follows from that camera's intrinsics
alone (``cv2.solvePnP``). Distances are the same in every camera frame, so for any two instants
``t_k``, ``t_l`` the distance the board moved, ``|X(t_k) - X(t_l)|``, is the same seen from
either camera. With camera b's frames at ``t_b + offset`` on camera a's clock and camera a's
trajectory interpolated linearly to those instants, the offset is the one that minimises

    ``D(offset) = RMS over k < l and four board points p of |X_a,p(t_k) - X_a,p(t_l)| -
    |X_b,p(k) - X_b,p(l)|``.

No relative pose and no bundle adjustment enter, so the result can judge the pairing that a
calibration was made with.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from dempath_calib.board import BoardSpec
from dempath_calib.camera import CameraModel

FloatArray = NDArray[np.float64]
MIN_CORNERS = 6  # least corners for a board pose


@dataclass(frozen=True)
class MotionOffset:
    """The clock offset that best matches the board's motion in both cameras.

    Attributes:
        offset_s: add to camera b's stamps to put them on camera a's clock [s].
        rms_mm: ``D`` at the best offset [mm].
        rms_zero_mm: ``D`` with the stamps as recorded (offset 0) [mm].
        offsets_s: the candidate offsets [s].
        rms_curve_mm: ``D`` of each candidate [mm] (NaN where too few frames overlap).
    """

    offset_s: float
    rms_mm: float
    rms_zero_mm: float
    offsets_s: FloatArray
    rms_curve_mm: FloatArray


def board_points(board: BoardSpec) -> FloatArray:
    """(4, 3) board-frame points followed: the chessboard's centre and three outer corners."""
    w, h = board.size_m
    return np.array([board.center_m, [0.0, 0.0, 0.0], [w, 0.0, 0.0], [0.0, h, 0.0]])


def board_trajectory(corners: FloatArray, camera: CameraModel, board: BoardSpec,
                     min_corners: int = MIN_CORNERS) -> FloatArray:
    """Board points in the camera's frame per frame, from that camera's intrinsics alone.

    Args:
        corners: (n_frames, n_corners, 2) px, NaN where unseen.
        camera: intrinsics and distortion (its pose is not used).
        board: the printed board.
        min_corners: least corners for a pose.

    Returns:
        (n_frames, 4, 3) m (``board_points`` in the camera frame), NaN where unseen.
    """
    obj, pts = board.object_points(), board_points(board)
    out = np.full((len(corners), len(pts), 3), np.nan)
    for i, c in enumerate(np.asarray(corners, np.float64)):
        seen = np.isfinite(c).all(1)
        if seen.sum() < min_corners:
            continue
        ok, rvec, tvec = cv2.solvePnP(obj[seen], c[seen], camera.K, camera.dist,
                                      flags=cv2.SOLVEPNP_IPPE)
        if ok:
            ok, rvec, tvec = cv2.solvePnP(obj[seen], c[seen], camera.K, camera.dist, rvec, tvec,
                                          True, cv2.SOLVEPNP_ITERATIVE)
        if ok and tvec[2, 0] > 0:
            out[i] = pts @ cv2.Rodrigues(rvec)[0].T + tvec.ravel()
    return out


def motion_mismatch_mm(stamps_a: FloatArray, traj_a: FloatArray, stamps_b: FloatArray,
                       traj_b: FloatArray, offset_s: float) -> tuple[float, int]:
    """``D(offset)`` [mm] and the number of camera-b frames it used (see the module text)."""
    ta, tb = np.asarray(stamps_a, np.float64), np.asarray(stamps_b, np.float64) + offset_s
    ok_a = np.asarray(np.isfinite(traj_a).all(axis=(1, 2)), bool)
    j = np.clip(np.searchsorted(ta, tb) - 1, 0, max(len(ta) - 2, 0))
    valid = (tb >= ta[0]) & (tb <= ta[-1]) & np.isfinite(traj_b).all(axis=(1, 2))
    valid &= ok_a[j] & ok_a[np.minimum(j + 1, len(ta) - 1)]
    k = np.flatnonzero(valid)
    if len(k) < 3:
        return float('nan'), len(k)
    w = ((tb[k] - ta[j[k]]) / (ta[j[k] + 1] - ta[j[k]]))[:, None, None]
    xa = (1 - w) * traj_a[j[k]] + w * traj_a[j[k] + 1]
    xb = traj_b[k]
    i, m = np.triu_indices(len(k), 1)
    diff = (np.linalg.norm(xa[i] - xa[m], axis=2) - np.linalg.norm(xb[i] - xb[m], axis=2))
    return float(1e3 * np.sqrt(np.mean(diff ** 2))), len(k)


def motion_offset(stamps_a: FloatArray, traj_a: FloatArray, stamps_b: FloatArray,
                  traj_b: FloatArray, max_offset_s: float = 0.5,
                  step_s: float = 0.005) -> MotionOffset:
    """Offset of camera b's clock that makes the board's motion agree in both cameras.

    Args:
        stamps_a: (n_a,) increasing frame times of camera a [s].
        traj_a: (n_a, 4, 3) ``board_trajectory`` of camera a.
        stamps_b: (n_b,) frame times of camera b [s].
        traj_b: (n_b, 4, 3) ``board_trajectory`` of camera b.
        max_offset_s: search range [s].
        step_s: grid step; the minimum is refined by a parabola through its neighbours [s].

    Returns:
        The best offset with the whole curve. NaN offset if no candidate has 3 frames.
    """
    cand = np.asarray(np.arange(-max_offset_s, max_offset_s + 0.5 * step_s, step_s), np.float64)
    curve = np.array([motion_mismatch_mm(stamps_a, traj_a, stamps_b, traj_b, float(o))[0]
                      for o in cand])
    zero = motion_mismatch_mm(stamps_a, traj_a, stamps_b, traj_b, 0.0)[0]
    if not np.isfinite(curve).any():
        return MotionOffset(float('nan'), float('nan'), zero, cand, curve)
    offset, best = grid_minimum(cand, curve)
    return MotionOffset(offset, float(curve[best]), zero, cand, curve)


def grid_minimum(x: FloatArray, y: FloatArray) -> tuple[float, int]:
    """Minimum of ``y`` over the evenly spaced grid ``x``, refined by a parabola.

    The parabola goes through the lowest finite point and its two neighbours:
    ``x* = x_i + 0.5 h (y_(i-1) - y_(i+1)) / (y_(i-1) - 2 y_i + y_(i+1))`` (grid step ``h``).

    Returns:
        ``(x*, i)`` with ``i`` the index of the lowest grid point.
    """
    best = int(np.nanargmin(y))
    out = float(x[best])
    if 0 < best < len(x) - 1 and np.isfinite(y[best - 1:best + 2]).all():
        y0, y1, y2 = y[best - 1:best + 2]
        den = y0 - 2 * y1 + y2
        out += float(0.5 * (y0 - y2) / den * (x[1] - x[0])) if den > 0 else 0.0
    return out, best
