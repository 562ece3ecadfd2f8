"""Two-camera bundle adjustment and the world frame.

Unknowns: each camera's intrinsics (fx, fy, cx, cy and the free distortion coefficients), the
front camera's pose relative to the side camera (6), and every frame's board pose in the side
camera's frame (6 per frame). Residuals: reprojection of every detected corner in every camera,
with a Huber loss. Solved by ``scipy.optimize.least_squares`` (trust-region reflective) with the
sparse Jacobian pattern, started from the per-camera intrinsic results.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares
from scipy.sparse import coo_matrix

from dempath_calib.board import BoardSpec
from dempath_calib.errors import CalibrationError, NotEnoughViewsError
from dempath_calib.intrinsics import IntrinsicResult

LOG = logging.getLogger(__name__)
FloatArray = NDArray[np.float64]


def rotate(rvec: FloatArray, pts: FloatArray) -> FloatArray:
    """Rotate points (m, 3) by rotation vectors (m, 3) (Rodrigues' formula)."""
    theta = np.linalg.norm(rvec, axis=1, keepdims=True)
    with np.errstate(invalid='ignore', divide='ignore'):
        k = np.where(theta > 1e-12, rvec / theta, 0.0)
    cos, sin = np.cos(theta), np.sin(theta)
    kxp = np.cross(k, pts)
    return pts * cos + kxp * sin + k * np.sum(k * pts, axis=1, keepdims=True) * (1 - cos)


def distort_project(pc: FloatArray, intr: FloatArray) -> FloatArray:
    """Pixels (m, 2) of camera-frame points (m, 3) [m].

    ``intr`` is (m, 9): fx fy cx cy k1 k2 p1 p2 k3 (OpenCV's radial-tangential model).
    """
    x, y = pc[:, 0] / pc[:, 2], pc[:, 1] / pc[:, 2]
    k1, k2, p1, p2, k3 = intr[:, 4], intr[:, 5], intr[:, 6], intr[:, 7], intr[:, 8]
    r2 = x * x + y * y
    radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
    xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
    yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
    return np.column_stack([intr[:, 0] * xd + intr[:, 2], intr[:, 1] * yd + intr[:, 3]])


@dataclass
class _Problem:
    """Observation tables of the bundle adjustment."""

    frame: NDArray[np.int64]  # (m,) index into the adjusted frames
    cam: NDArray[np.int64]  # (m,) 0 side, 1 front
    obj: FloatArray  # (m, 3) board-frame corner [m]
    uv: FloatArray  # (m, 2) observed pixel
    free: NDArray[np.bool_]  # (2, 9) which intrinsics are adjusted
    n_frames: int

    def unpack(self, x: FloatArray, base: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        intr = base.copy()
        n_i = int(self.free.sum())
        intr[self.free] = x[:n_i]
        rel = x[n_i:n_i + 6]
        poses = x[n_i + 6:].reshape(self.n_frames, 6)
        return intr, rel, poses

    def residuals(self, x: FloatArray, base: FloatArray) -> FloatArray:
        intr, rel, poses = self.unpack(x, base)
        p = rotate(poses[self.frame, :3], self.obj) + poses[self.frame, 3:]
        front = self.cam == 1
        p[front] = rotate(np.repeat(rel[None, :3], front.sum(), 0), p[front]) + rel[3:]
        return (distort_project(p, intr[self.cam]) - self.uv).ravel()

    def sparsity(self) -> coo_matrix:
        """0/1 pattern of the Jacobian (residual rows x parameters)."""
        n_i = int(self.free.sum())
        m = len(self.frame)
        col_of = np.cumsum(self.free.ravel()).reshape(2, 9) - 1
        rows, cols = [], []
        for obs_row in (2 * np.arange(m), 2 * np.arange(m) + 1):
            for c in range(2):
                sel = obs_row[self.cam == c]
                for col in col_of[c][self.free[c]]:
                    rows.append(sel)
                    cols.append(np.full(len(sel), col))
            sel = obs_row[self.cam == 1]
            for k in range(6):
                rows += [sel, obs_row]
                cols += [np.full(len(sel), n_i + k), n_i + 6 + 6 * self.frame + k]
        r, c = np.concatenate(rows), np.concatenate(cols)
        return coo_matrix((np.ones(len(r), np.int8), (r, c)),
                          shape=(2 * m, n_i + 6 + 6 * self.n_frames))


@dataclass(frozen=True)
class StereoResult:
    """Bundle-adjusted two-camera model, in the side camera's frame.

    Attributes:
        intrinsics: (2, 9) fx fy cx cy k1 k2 p1 p2 k3 of side and front.
        rel_rvec: (3,) rotation side camera -> front camera.
        rel_t: (3,) translation side -> front [m] (``x_f = R x_s + t``).
        frames: (n,) indices of the adjusted frames in the input.
        board_rvecs: (n, 3) board -> side-camera rotations.
        board_tvecs: (n, 3) board -> side-camera translations [m].
        rmse_px: (2,) reprojection RMSE per camera after adjustment [px].
        frame_rmse_px: (n, 2) per-frame, per-camera RMSE [px] (NaN where unseen).
    """

    intrinsics: FloatArray
    rel_rvec: FloatArray
    rel_t: FloatArray
    frames: NDArray[np.int64]
    board_rvecs: FloatArray
    board_tvecs: FloatArray
    rmse_px: FloatArray
    frame_rmse_px: FloatArray


def _pose_inits(corners: FloatArray, board: BoardSpec, intr: list[IntrinsicResult],
                min_corners: int) -> tuple[NDArray[np.bool_], FloatArray]:
    """(n_frames, 2) views each camera uses, and (n_frames, 2, 6) PnP board poses (NaN if none)."""
    n = corners.shape[0]
    used = np.zeros((n, 2), bool)
    poses = np.full((n, 2, 6), np.nan)
    obj = board.object_points()
    for c in range(2):
        for i in range(n):
            seen = ~np.isnan(corners[i, c, :, 0])
            if seen.sum() < min_corners:
                continue
            ok, rvec, tvec = cv2.solvePnP(obj[seen], corners[i, c, seen], intr[c].K,
                                          intr[c].dist, flags=cv2.SOLVEPNP_ITERATIVE)
            if ok and tvec[2, 0] > 0:
                used[i, c] = True
                poses[i, c] = np.concatenate([rvec.ravel(), tvec.ravel()])
    return used, poses


def _relative_pose(poses: FloatArray, shared: NDArray[np.bool_]) -> FloatArray:
    """(6,) median side->front pose over the frames both cameras see."""
    rels = []
    for i in np.flatnonzero(shared):
        rs, rf = cv2.Rodrigues(poses[i, 0, :3])[0], cv2.Rodrigues(poses[i, 1, :3])[0]
        r = rf @ rs.T
        t = poses[i, 1, 3:] - r @ poses[i, 0, 3:]
        rels.append(np.concatenate([cv2.Rodrigues(r)[0].ravel(), t]))
    return np.median(np.array(rels), axis=0)


def _compose(rel: FloatArray, front_pose: FloatArray) -> FloatArray:
    """Board->side pose from board->front and side->front (6,)."""
    r_rel = cv2.Rodrigues(rel[:3])[0]
    r_f = cv2.Rodrigues(front_pose[:3])[0]
    r_s = r_rel.T @ r_f
    return np.concatenate([cv2.Rodrigues(r_s)[0].ravel(), r_rel.T @ (front_pose[3:] - rel[3:])])


def bundle_adjust(corners: FloatArray, board: BoardSpec, intr: list[IntrinsicResult],
                  free: NDArray[np.bool_], min_corners: int = 6, min_shared: int = 3,
                  robust_px: float = 1.0) -> StereoResult:
    """Refine both cameras and their relative pose over all frames.

    Args:
        corners: (n_frames, 2, n_corners, 2) px, NaN where unseen; camera 0 side, 1 front.
        board: the target.
        intr: per-camera intrinsic results (starting values).
        free: (2, 9) which of fx fy cx cy k1 k2 p1 p2 k3 to adjust per camera.
        min_corners: least corners for a camera's view of a frame to be used.
        min_shared: least frames both cameras see.
        robust_px: scale of the Huber loss [px].

    Raises:
        NotEnoughViewsError: fewer than ``min_shared`` frames seen by both cameras.
        CalibrationError: the optimisation failed.
    """
    used, pnp = _pose_inits(corners, board, intr, min_corners)
    shared = used.all(1)
    if shared.sum() < min_shared:
        msg = (f'stereo: {int(shared.sum())} frames show the board to both cameras '
               f'(>= {min_corners} corners each), need {min_shared}: '
               f'{min_shared - int(shared.sum())} more in the shared field of view')
        raise NotEnoughViewsError(msg)
    rel = _relative_pose(pnp, shared)
    frames = np.flatnonzero(used.any(1))
    init = np.array([pnp[i, 0] if used[i, 0] else _compose(rel, pnp[i, 1]) for i in frames])
    prob = _tables(corners, board, used, frames, free)
    base = np.array([[r.K[0, 0], r.K[1, 1], r.K[0, 2], r.K[1, 2], *r.dist] for r in intr])
    x0 = np.concatenate([base[free], rel, init.ravel()])
    try:
        sol = least_squares(prob.residuals, x0, jac_sparsity=prob.sparsity(), args=(base,),
                            method='trf', loss='huber', f_scale=robust_px, x_scale='jac',
                            max_nfev=200, xtol=1e-10, ftol=1e-10)
    except (ValueError, np.linalg.LinAlgError) as err:
        msg = f'stereo: bundle adjustment over {len(frames)} frames failed ({err})'
        raise CalibrationError(msg) from err
    intr_x, rel_x, poses = prob.unpack(sol.x, base)
    res = sol.fun.reshape(-1, 2)
    sq = np.sum(res ** 2, axis=1)
    rmse = np.array([np.sqrt(sq[prob.cam == c].mean()) for c in range(2)])
    frame_rmse = np.full((len(frames), 2), np.nan)
    for c in range(2):
        sel = prob.cam == c
        sums = np.bincount(prob.frame[sel], sq[sel], len(frames))
        counts = np.bincount(prob.frame[sel], minlength=len(frames))
        with np.errstate(invalid='ignore', divide='ignore'):
            frame_rmse[:, c] = np.sqrt(sums / counts)
    LOG.info('stereo: %d frames (%d shared), RMSE side %.3f px, front %.3f px, %d evaluations',
             len(frames), int(shared.sum()), rmse[0], rmse[1], sol.nfev)
    return StereoResult(intr_x, rel_x[:3].copy(), rel_x[3:].copy(), frames, poses[:, :3].copy(),
                        poses[:, 3:].copy(), rmse, frame_rmse)


def _tables(corners: FloatArray, board: BoardSpec, used: NDArray[np.bool_],
            frames: NDArray[np.int64], free: NDArray[np.bool_]) -> _Problem:
    """Flatten the observations of the adjusted frames."""
    obj = board.object_points()
    fr, cam, pts, uv = [], [], [], []
    for j, i in enumerate(frames):
        for c in range(2):
            if not used[i, c]:
                continue
            seen = np.flatnonzero(~np.isnan(corners[i, c, :, 0]))
            fr.append(np.full(len(seen), j))
            cam.append(np.full(len(seen), c))
            pts.append(obj[seen])
            uv.append(corners[i, c, seen])
    return _Problem(np.concatenate(fr), np.concatenate(cam), np.concatenate(pts),
                    np.concatenate(uv), free, len(frames))
