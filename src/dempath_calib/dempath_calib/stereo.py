"""Two-camera bundle adjustment and the world frame.

Unknowns: each camera's intrinsics (fx, fy, cx, cy and the free distortion coefficients), the
front camera's pose relative to the side camera (6), and every frame's board pose in the side
camera's frame (6 per frame). Residuals: reprojection of every detected corner in every camera,
with a Huber loss. Solved by a robust Levenberg-Marquardt (iteratively reweighted) whose
Jacobian is sparse (forward differences, one residual evaluation per group of independent
columns) and whose small normal matrix is solved exactly; started from the per-camera results.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray
from scipy.sparse import csr_matrix

from dempath_calib.board import BoardSpec
from dempath_calib.errors import CalibrationError, NotEnoughViewsError
from dempath_calib.intrinsics import OUTLIER_FACTOR, OUTLIER_FLOOR_PX, IntrinsicResult

LOG = logging.getLogger(__name__)
FloatArray = NDArray[np.float64]


def rotation_matrices(rvec: FloatArray) -> FloatArray:
    """(k, 3, 3) rotation matrices of rotation vectors (k, 3) (Rodrigues' formula)."""
    theta = np.linalg.norm(rvec, axis=1)
    safe = np.where(theta > 1e-12, theta, 1.0)
    k = rvec / safe[:, None]
    kx = np.zeros((len(rvec), 3, 3))
    kx[:, 0, 1], kx[:, 0, 2], kx[:, 1, 2] = -k[:, 2], k[:, 1], -k[:, 0]
    kx[:, 1, 0], kx[:, 2, 0], kx[:, 2, 1] = k[:, 2], -k[:, 1], k[:, 0]
    s, c = np.sin(theta)[:, None, None], np.cos(theta)[:, None, None]
    out = np.eye(3)[None] + s * kx + (1 - c) * (kx @ kx)
    out[theta <= 1e-12] = np.eye(3)
    return np.asarray(out, np.float64)


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
        """(2m,) reprojection residuals [px] of every observation."""
        intr, rel, poses = self.unpack(x, base)
        rot = rotation_matrices(poses[:, :3])[self.frame]
        p = np.einsum('mij,mj->mi', rot, self.obj) + poses[self.frame, 3:]
        front = self.cam == 1
        p[front] = p[front] @ rotation_matrices(rel[None, :3])[0].T + rel[3:]
        return (distort_project(p, intr[self.cam]) - self.uv).ravel()

    def jacobian(self, x: FloatArray, base: FloatArray, r0: FloatArray) -> csr_matrix:
        """Sparse forward-difference Jacobian (2m, n_params), one evaluation per column group.

        Columns that never share a residual row are perturbed together: each intrinsic and
        relative-pose parameter alone, and the k-th pose parameter of every frame at once.
        """
        n_i = int(self.free.sum())
        m = len(self.frame)
        col_of = np.cumsum(self.free.ravel()).reshape(2, 9) - 1
        cam2 = np.repeat(self.cam, 2)
        frame2 = np.repeat(self.frame, 2)
        rows_all = np.arange(2 * m)
        groups: list[tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]]] = []
        for c in range(2):
            for col in col_of[c][self.free[c]]:
                sel = rows_all[cam2 == c]
                groups.append((np.array([col]), sel, np.full(len(sel), col)))
        front = rows_all[cam2 == 1]
        for k in range(6):
            groups.append((np.array([n_i + k]), front, np.full(len(front), n_i + k)))
        for k in range(6):
            frame_cols = n_i + 6 + 6 * np.arange(self.n_frames) + k
            groups.append((frame_cols, rows_all, n_i + 6 + 6 * frame2 + k))
        data, rr, cc = [], [], []
        for cols, rows, row_cols in groups:
            step = self.FD_STEP * np.maximum(1.0, np.abs(x[cols]))
            xp = x.copy()
            xp[cols] += step
            deriv = (self.residuals(xp, base) - r0)[rows]
            full_step = np.zeros(len(x))
            full_step[cols] = step
            data.append(deriv / full_step[row_cols])
            rr.append(rows)
            cc.append(row_cols)
        return csr_matrix((np.concatenate(data), (np.concatenate(rr), np.concatenate(cc))),
                          shape=(2 * m, len(x)))

    FD_STEP = 1e-7  # relative forward-difference step


def _huber_weights(r: FloatArray, scale: float) -> FloatArray:
    """(2m,) IRLS weights of the Huber loss on each 2-D residual's length."""
    norm = np.repeat(np.linalg.norm(r.reshape(-1, 2), axis=1), 2)
    return np.where(norm <= scale, 1.0, scale / np.maximum(norm, 1e-12))


def _huber_cost(r: FloatArray, scale: float) -> float:
    norm = np.linalg.norm(r.reshape(-1, 2), axis=1)
    return float(np.sum(np.where(norm <= scale, 0.5 * norm ** 2, scale * (norm - 0.5 * scale))))


def levenberg_marquardt(prob: _Problem, x0: FloatArray, base: FloatArray, robust_px: float,
                        max_iter: int = 100, tol: float = 1e-10) -> tuple[FloatArray, int]:
    """Robust (Huber, IRLS) Levenberg-Marquardt with Marquardt's diagonal scaling.

    The normal matrix is small (parameters squared), so each step is an exact dense solve.

    Returns:
        ``(x, iterations)``.
    """
    x, lam = x0.copy(), 1e-3
    r = prob.residuals(x, base)
    cost = _huber_cost(r, robust_px)
    for it in range(1, max_iter + 1):
        jac = prob.jacobian(x, base, r)
        w = _huber_weights(r, robust_px)
        a = (jac.T @ jac.multiply(w[:, None])).toarray()
        g = jac.T @ (w * r)
        diag = np.maximum(np.diag(a), 1e-12)
        while True:
            dx = np.linalg.solve(a + lam * np.diag(diag), -g)
            r_new = prob.residuals(x + dx, base)
            cost_new = _huber_cost(r_new, robust_px)
            if cost_new <= cost or lam > 1e12:
                break
            lam *= 10
        if cost_new > cost:
            return x, it
        done = cost - cost_new <= tol * max(cost, 1e-12)
        x, r, cost, lam = x + dx, r_new, cost_new, max(lam / 10, 1e-9)
        if done:
            return x, it
    return x, max_iter


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
    """(n_frames, 2) views each camera uses, and (n_frames, 2, 6) PnP board poses (NaN if none).

    A view is dropped when its PnP reprojection RMSE is an outlier (as in the intrinsic step).
    """
    n = corners.shape[0]
    used = np.zeros((n, 2), bool)
    poses = np.full((n, 2, 6), np.nan)
    rmse = np.full((n, 2), np.nan)
    obj = board.object_points()
    for c in range(2):
        for i in range(n):
            seen = ~np.isnan(corners[i, c, :, 0])
            if seen.sum() < min_corners:
                continue
            ok, rvec, tvec = cv2.solvePnP(obj[seen], corners[i, c, seen], intr[c].K,
                                          intr[c].dist, flags=cv2.SOLVEPNP_IPPE)
            if ok and tvec[2, 0] > 0:
                used[i, c] = True
                poses[i, c] = np.concatenate([rvec.ravel(), tvec.ravel()])
                uv = cv2.projectPoints(obj[seen], rvec, tvec, intr[c].K, intr[c].dist)[0]
                rmse[i, c] = np.sqrt(np.mean(np.sum((uv.reshape(-1, 2)
                                                     - corners[i, c, seen]) ** 2, axis=1)))
        if used[:, c].any():
            limit = max(OUTLIER_FACTOR * np.nanmedian(rmse[:, c]), OUTLIER_FLOOR_PX)
            used[:, c] &= ~(rmse[:, c] > limit)
    return used, poses


def _relative_pose(poses: FloatArray, shared: NDArray[np.bool_]) -> FloatArray:
    """(6,) median side->front pose over the frames both cameras see."""
    rels = []
    for i in np.flatnonzero(shared):
        rs = np.asarray(cv2.Rodrigues(poses[i, 0, :3])[0], np.float64)
        rf = np.asarray(cv2.Rodrigues(poses[i, 1, :3])[0], np.float64)
        r = rf @ rs.T
        t = poses[i, 1, 3:] - r @ poses[i, 0, 3:]
        rels.append(np.concatenate([np.asarray(cv2.Rodrigues(r)[0]).ravel(), t]))
    return np.asarray(np.median(np.array(rels), axis=0), np.float64)


def _compose(rel: FloatArray, front_pose: FloatArray) -> FloatArray:
    """Board->side pose from board->front and side->front (6,)."""
    r_rel = np.asarray(cv2.Rodrigues(rel[:3])[0], np.float64)
    r_f = np.asarray(cv2.Rodrigues(front_pose[:3])[0], np.float64)
    r_s = np.asarray(r_rel.T @ r_f, np.float64)
    rvec = np.asarray(cv2.Rodrigues(r_s)[0], np.float64).ravel()
    return np.concatenate([rvec, r_rel.T @ (front_pose[3:] - rel[3:])])


def bundle_adjust(corners: FloatArray, board: BoardSpec, intr: list[IntrinsicResult],
                  free: NDArray[np.bool_], min_corners: int = 6, min_shared: int = 3,
                  robust_px: float = 1.0, max_iter: int = 100) -> StereoResult:
    """Refine both cameras and their relative pose over all frames.

    Args:
        corners: (n_frames, 2, n_corners, 2) px, NaN where unseen; camera 0 side, 1 front.
        board: the target.
        intr: per-camera intrinsic results (starting values).
        free: (2, 9) which of fx fy cx cy k1 k2 p1 p2 k3 to adjust per camera.
        min_corners: least corners for a camera's view of a frame to be used.
        min_shared: least frames both cameras see.
        robust_px: scale of the Huber loss [px].
        max_iter: iteration limit of the Levenberg-Marquardt solver.

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
    rel = _relative_pose(pnp, np.asarray(shared, bool))
    frames = np.flatnonzero(used.any(1))
    init = np.array([pnp[i, 0] if used[i, 0] else _compose(rel, pnp[i, 1]) for i in frames])
    prob = _tables(corners, board, used, frames, free)
    base = np.array([[r.K[0, 0], r.K[1, 1], r.K[0, 2], r.K[1, 2], *r.dist] for r in intr])
    x0 = np.concatenate([base[free], rel, init.ravel()])
    try:
        x, n_iter = levenberg_marquardt(prob, x0, base, robust_px, max_iter)
    except np.linalg.LinAlgError as err:
        msg = f'stereo: bundle adjustment over {len(frames)} frames failed ({err})'
        raise CalibrationError(msg) from err
    intr_x, rel_x, poses = prob.unpack(x, base)
    rmse, frame_rmse = _rmse(prob, prob.residuals(x, base))
    LOG.info('stereo: %d frames (%d shared), RMSE side %.3f px, front %.3f px, %d iterations',
             len(frames), int(shared.sum()), rmse[0], rmse[1], n_iter)
    return StereoResult(intr_x, rel_x[:3].copy(), rel_x[3:].copy(), frames, poses[:, :3].copy(),
                        poses[:, 3:].copy(), rmse, frame_rmse)


def _rmse(prob: _Problem, residuals: FloatArray) -> tuple[FloatArray, FloatArray]:
    """(2,) RMSE per camera and (n_frames, 2) per frame and camera [px] (NaN where unseen)."""
    sq = np.sum(residuals.reshape(-1, 2) ** 2, axis=1)
    rmse = np.array([np.sqrt(sq[prob.cam == c].mean()) for c in range(2)])
    frame_rmse = np.full((prob.n_frames, 2), np.nan)
    for c in range(2):
        sel = prob.cam == c
        sums = np.bincount(prob.frame[sel], sq[sel], prob.n_frames)
        counts = np.bincount(prob.frame[sel], minlength=prob.n_frames)
        with np.errstate(invalid='ignore', divide='ignore'):
            frame_rmse[:, c] = np.sqrt(sums / counts)
    return rmse, frame_rmse


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
