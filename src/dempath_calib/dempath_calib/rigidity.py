"""Checks of a two-camera calibration that depend on no calibration optimiser.

Both checks take board corners detected by the two cameras at the same instant and a calibration
(any tool's, read into ``StereoCalibration``), and measure what the printed board and the
geometry of two cameras demand:

- **Board rigidity** (``board_rigidity``): every corner seen by both cameras is triangulated
  (linear DLT of the undistorted rays, ``verify.triangulate``) and every pair of corners in a
  frame, not only neighbours, is compared with the printed board:
  ``e_ij = |X_i - X_j| - |P_i - P_j|`` with ``X`` triangulated and ``P`` the board's corner
  positions. A wrong baseline scales the board (``e`` grows with the separation ``|P_i - P_j|``);
  a wrong relative rotation or lens bends it.
- **Epipolar error** (``epipolar_errors``): with the relative pose ``x_b = R x_a + t`` of camera
  b to camera a, the essential matrix is ``E = [t]x R`` and the fundamental matrix of the ideal
  (undistorted) pixels ``F = K_b^-T E K_a^-1``. For a pair ``(u_a, u_b)`` of homogeneous ideal
  pixels, ``l_b = F u_a`` is the epipolar line in b and ``l_a = F^T u_b`` the line in a; the
  symmetric error is ``0.5 (|u_b . l_b| / |l_b[:2]| + |u_a . l_a| / |l_a[:2]|)`` px. It does not
  depend on the baseline length, only on its direction and the relative rotation.

Both need truly simultaneous frames: a board that moves between the two exposures breaks both
measures exactly as a wrong calibration does (``pairing.pair_frames`` interpolates one camera's
corners to the other's instant; ``motion_mm`` tells how far the board moved).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from dempath_calib.board import BoardSpec
from dempath_calib.camera import StereoCalibration
from dempath_calib.verify import relative_pose, triangulate

FloatArray = NDArray[np.float64]
MIN_CORNERS = 4  # least corners seen by both cameras for a frame to count


@dataclass(frozen=True)
class SeparationBin:
    """Length errors of the corner pairs whose printed separation falls in ``[low, high)`` mm."""

    low_mm: float
    high_mm: float
    n: int
    mean_mm: float
    rms_mm: float
    max_mm: float


@dataclass(frozen=True)
class RigidityResult:
    """Errors of all triangulated corner-pair distances against the printed board.

    Attributes:
        n_frames: frames with at least ``MIN_CORNERS`` corners seen by both cameras.
        n_corners: triangulated corners.
        n_pairs: corner pairs compared.
        mean_mm: mean signed length error [mm].
        rms_mm: RMS length error [mm].
        max_mm: largest absolute length error [mm].
        scale_ppm: least-squares scale of measured over printed lengths, minus 1 [ppm]
            (``sum(d * d0) / sum(d0^2) - 1``).
        bins: the errors by printed separation (one bin per square of separation).
        errors_mm: every pair's signed error [mm].
        separations_mm: every pair's printed separation [mm].
    """

    n_frames: int
    n_corners: int
    n_pairs: int
    mean_mm: float
    rms_mm: float
    max_mm: float
    scale_ppm: float
    bins: list[SeparationBin] = field(default_factory=list)
    errors_mm: FloatArray = field(default_factory=lambda: np.zeros(0))
    separations_mm: FloatArray = field(default_factory=lambda: np.zeros(0))

    def summary(self) -> dict[str, float]:
        """The headline figures as a JSON-ready dict."""
        return {'frames': self.n_frames, 'corners': self.n_corners, 'pairs': self.n_pairs,
                'mean_mm': self.mean_mm, 'rms_mm': self.rms_mm, 'max_mm': self.max_mm,
                'scale_ppm': self.scale_ppm}


def board_rigidity(calib: StereoCalibration, corners: FloatArray, board: BoardSpec,
                   min_corners: int = MIN_CORNERS) -> RigidityResult:
    """Triangulate every corner both cameras see in a frame and compare all pair distances.

    Args:
        calib: the two cameras (camera 0 = ``side``, 1 = ``front``).
        corners: (n_frames, 2, n_corners, 2) px of simultaneous frames, NaN where unseen.
        board: the printed board.
        min_corners: least corners seen by both cameras for a frame to count.

    Returns:
        The errors ``e_ij = |X_i - X_j| - |P_i - P_j|`` over all frames and corner pairs.
    """
    obj = board.object_points()
    errs, seps = [], []
    n_frames = n_corners = 0
    for frame in np.asarray(corners, np.float64):
        both = np.flatnonzero(np.isfinite(frame).all(axis=(0, 2)))
        if len(both) < min_corners:
            continue
        xyz = triangulate(calib, frame[0, both], frame[1, both])
        i, j = np.triu_indices(len(both), 1)
        d0 = np.linalg.norm(obj[both[i]] - obj[both[j]], axis=1)
        errs.append(np.linalg.norm(xyz[i] - xyz[j], axis=1) - d0)
        seps.append(d0)
        n_frames += 1
        n_corners += len(both)
    if not errs:
        nan = float('nan')
        return RigidityResult(0, 0, 0, nan, nan, nan, nan)
    e, s = np.concatenate(errs) * 1e3, np.concatenate(seps) * 1e3
    scale = float(np.sum((e + s) * s) / np.sum(s * s) - 1.0)
    return RigidityResult(n_frames, n_corners, len(e), float(e.mean()),
                          float(np.sqrt(np.mean(e ** 2))), float(np.abs(e).max()), 1e6 * scale,
                          _bins(e, s, board.square_m * 1e3), e, s)


def _bins(e: FloatArray, s: FloatArray, square_mm: float) -> list[SeparationBin]:
    """Errors grouped by printed separation, one square wide: [1, 2), [2, 3)... squares."""
    out = []
    for k in range(1, int(np.floor(s.max() / square_mm + 1e-9)) + 1):
        sel = (s >= k * square_mm - 1e-6) & (s < (k + 1) * square_mm - 1e-6)
        if sel.any():
            out.append(SeparationBin(k * square_mm, (k + 1) * square_mm, int(sel.sum()),
                                     float(e[sel].mean()), float(np.sqrt(np.mean(e[sel] ** 2))),
                                     float(np.abs(e[sel]).max())))
    return out


def fundamental_matrix(calib: StereoCalibration) -> FloatArray:
    """(3, 3) ``F = K_f^-T [t]x R K_s^-1`` of the ideal pixels, side (a) to front (b)."""
    r, t = relative_pose(calib.side, calib.front)
    tx = np.array([[0.0, -t[2], t[1]], [t[2], 0.0, -t[0]], [-t[1], t[0], 0.0]])
    f = np.linalg.inv(calib.front.K).T @ tx @ r @ np.linalg.inv(calib.side.K)
    return np.asarray(f / np.linalg.norm(f), np.float64)


def epipolar_errors(calib: StereoCalibration, uv_side: FloatArray,
                    uv_front: FloatArray) -> FloatArray:
    """Symmetric point-to-epipolar-line distance of corner pairs [px].

    Args:
        calib: the two cameras.
        uv_side: (n, 2) distorted px in the side camera.
        uv_front: (n, 2) distorted px in the front camera, the same physical points.

    Returns:
        (n,) ``0.5 (d(u_f, F u_s) + d(u_s, F^T u_f))`` in ideal (undistorted) pixels, NaN where
        an input is NaN.
    """
    out = np.full(len(uv_side), np.nan)
    ok = np.isfinite(uv_side).all(1) & np.isfinite(uv_front).all(1)
    if not ok.any():
        return out
    a = np.column_stack([calib.side.undistort_points(uv_side[ok]), np.ones(int(ok.sum()))])
    b = np.column_stack([calib.front.undistort_points(uv_front[ok]), np.ones(int(ok.sum()))])
    f = fundamental_matrix(calib)
    lb, la = a @ f.T, b @ f
    alg = np.abs(np.sum(b * lb, axis=1))
    out[ok] = 0.5 * (alg / np.linalg.norm(lb[:, :2], axis=1)
                     + alg / np.linalg.norm(la[:, :2], axis=1))
    return out


def frame_epipolar_errors(calib: StereoCalibration, corners: FloatArray) -> FloatArray:
    """Epipolar errors [px] of every corner both cameras see, over all frames (flat)."""
    c = np.asarray(corners, np.float64)
    e = epipolar_errors(calib, c[:, 0].reshape(-1, 2), c[:, 1].reshape(-1, 2))
    return np.asarray(e[np.isfinite(e)], np.float64)
