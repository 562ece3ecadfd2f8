"""The two-camera calibrator: streaming detection (``Calibrator``) and the batch solve.

A ``Calibrator`` takes images one at a time from either camera (``add_image``), detects the
board, and keeps fixed-shape detections; ``progress()`` tells how many views each camera has and
how much of its image they cover; ``solve()`` pairs the frames by time, calibrates each camera,
bundle-adjusts both, puts them in the world frame and builds the point set and the checks.
``calibrate_detections`` is the same solve for detections already in memory.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import cv2
import numpy as np
from numpy.typing import NDArray

from dempath_calib.board import PAPER_BOARD, SURFACE_ROT, BoardKind, BoardSpec, CornerDetector
from dempath_calib.camera import CameraModel, StereoCalibration
from dempath_calib.errors import CalibrationError
from dempath_calib.intrinsics import DistortionModel, IntrinsicResult, calibrate_intrinsics
from dempath_calib.pairing import DetectionStream, pair_frames
from dempath_calib.pointset import PointSet, make_point_set
from dempath_calib.stereo import StereoResult, bundle_adjust
from dempath_calib.syncmotion import grid_minimum
from dempath_calib.verify import distance_summary, neighbour_distances

LOG = logging.getLogger(__name__)
FloatArray = NDArray[np.float64]
CAMERA_NAMES = ('cam_side', 'cam_front')
WORLD_MODES = ('surface', 'side')
STATIC_TOL_M = 0.002  # board moved less than this between frames: still lying on the surface
STATIC_TOL_DEG = 0.5
OFFSET_SEARCH_ITER = 8  # LM iterations per offset candidate (poses only; enough to rank them)


@dataclass(frozen=True)
class CalibrationConfig:
    """Settings of a calibration.

    Attributes:
        board: the target.
        distortion: distortion model of both cameras.
        min_views: least usable views per camera.
        min_corners: least corners for a view to count.
        min_shared_views: least frames with the board seen by both cameras.
        world: 'surface' (world frame from the board lying on the sand in the first frames both
            cameras see) or 'side' (the side camera's frame).
        robust_px: Huber scale of the bundle adjustment [px].
        refine_intrinsics: let the bundle adjustment refine the intrinsics too.
        offset_s: front-camera clock offset [s] added to its stamps; None estimates it
            (``estimate_offset``).
        max_offset_s: search range of the offset estimate [s].
        image_size: (width, height) px of both cameras.
    """

    board: BoardSpec = PAPER_BOARD
    distortion: DistortionModel = DistortionModel.FULL
    min_views: int = 8
    min_corners: int = 6
    min_shared_views: int = 3
    world: str = 'surface'
    robust_px: float = 1.0
    refine_intrinsics: bool = True
    offset_s: float | None = 0.0
    max_offset_s: float = 0.5
    image_size: tuple[int, int] = (1920, 1080)

    def __post_init__(self) -> None:
        if self.world not in WORLD_MODES:
            msg = f'world: must be one of {WORLD_MODES}, got {self.world!r}'
            raise ValueError(msg)
        for name in ('min_views', 'min_corners', 'min_shared_views'):
            if getattr(self, name) < 1:
                msg = f'{name}: must be >= 1, got {getattr(self, name)}'
                raise ValueError(msg)
        if self.min_corners < 4:
            msg = f'min_corners: must be >= 4 for a board pose, got {self.min_corners}'
            raise ValueError(msg)
        if self.robust_px <= 0:
            msg = f'robust_px: must be > 0, got {self.robust_px}'
            raise ValueError(msg)


class Progress(NamedTuple):
    """Collection progress.

    Attributes:
        frames: images received per camera.
        views: usable views per camera (>= min_corners corners).
        skipped: images without a usable board per camera.
        coverage: fraction of the 3x3 image cells with corners, per camera.
    """

    frames: tuple[int, int]
    views: tuple[int, int]
    skipped: tuple[int, int]
    coverage: tuple[float, float]

    def line(self) -> str:
        """One log line."""
        return (f'views side {self.views[0]}, front {self.views[1]}; coverage side '
                f'{100 * self.coverage[0]:.0f}%, front {100 * self.coverage[1]:.0f}%; skipped '
                f'{self.skipped[0]}+{self.skipped[1]} of {self.frames[0]}+{self.frames[1]} images')


@dataclass(frozen=True)
class CalibrationResult:
    """Everything a calibration produced.

    Attributes:
        calibration: both cameras in the world frame (``info`` holds the headline figures).
        intrinsics: per-camera results of the intrinsic step.
        stereo: the bundle adjustment.
        stamps: (n_frames,) s of the paired frames.
        corners: (n_frames, 2, n_corners, 2) px detections, NaN where unseen.
        world_frames: indices of the frames that defined the world frame.
        point_set: every corner seen by both cameras, with its world position.
        report: JSON-ready figures (RMSE, views, corner spacing, per-view errors).
    """

    calibration: StereoCalibration
    intrinsics: tuple[IntrinsicResult, IntrinsicResult]
    stereo: StereoResult
    stamps: FloatArray
    corners: FloatArray
    world_frames: NDArray[np.int64]
    point_set: PointSet
    report: dict[str, Any] = field(default_factory=dict)


class Calibrator:
    """Streaming collector of board detections from the two cameras.

    Args:
        config: calibration settings.
    """

    def __init__(self, config: CalibrationConfig | None = None) -> None:
        self.config = config or CalibrationConfig()
        self.detector = CornerDetector(self.config.board)
        n = self.config.board.n_corners
        self.streams = (DetectionStream(n), DetectionStream(n))
        self._frames = [0, 0]
        self._views = [0, 0]
        self._cells = [np.zeros((3, 3), bool), np.zeros((3, 3), bool)]

    def add_image(self, camera: int, stamp_s: float, image: NDArray[np.uint8]) -> int:
        """Detect the board in one image of camera 0 (side) or 1 (front); returns corners found."""
        return self.add_detection(camera, stamp_s, self.detector.detect(image))

    def add_detection(self, camera: int, stamp_s: float, corners: FloatArray) -> int:
        """Store one image's detection (n_corners, 2) px; returns the number of corners."""
        self._frames[camera] += 1
        found = int((~np.isnan(corners[:, 0])).sum())
        if found < self.config.min_corners:
            return found
        self.streams[camera].add(stamp_s, corners)
        self._views[camera] += 1
        w, h = self.config.image_size
        pts = corners[~np.isnan(corners[:, 0])]
        cx = np.clip((pts[:, 0] * 3 // w).astype(int), 0, 2)
        cy = np.clip((pts[:, 1] * 3 // h).astype(int), 0, 2)
        self._cells[camera][cy, cx] = True
        return found

    def progress(self) -> Progress:
        """Views, skipped images and image coverage so far."""
        return Progress((self._frames[0], self._frames[1]), (self._views[0], self._views[1]),
                        (self._frames[0] - self._views[0], self._frames[1] - self._views[1]),
                        (float(self._cells[0].mean()), float(self._cells[1].mean())))

    def solve(self) -> CalibrationResult:
        """Calibrate each camera, find the clock offset if asked, pair, adjust and check."""
        cfg = self.config
        intr = tuple(calibrate_intrinsics(CAMERA_NAMES[c], self.streams[c].arrays()[1],
                                          cfg.board, cfg.image_size, cfg.distortion,
                                          cfg.min_views, cfg.min_corners) for c in range(2))
        offset = cfg.offset_s
        if offset is None:
            offset = estimate_offset(self.streams, intr, cfg)
        stamps, corners = pair_frames(*self.streams, offset_s=offset)
        result = calibrate_detections(corners, stamps, cfg, intr)
        result.report.update({'offset_s': offset, 'progress': self.progress()._asdict()})
        return result


def estimate_offset(streams: tuple[DetectionStream, DetectionStream],
                    intr: tuple[IntrinsicResult, ...], config: CalibrationConfig) -> float:
    """Front clock offset [s] that makes the two cameras agree best.

    For each candidate offset (a quarter of the front frame period apart, within
    ``config.max_offset_s``) the front corners are interpolated to the side frames' times and
    a bundle adjustment with fixed intrinsics gives the reprojection RMSE; the minimum is
    refined by a parabola through its neighbours.
    """
    tf = streams[1].arrays()[0]
    step = 0.25 * float(np.median(np.diff(tf))) if len(tf) > 1 else 0.01
    n = int(np.ceil(config.max_offset_s / step))
    candidates = np.arange(-n, n + 1) * step
    costs = np.full(len(candidates), np.inf)
    fixed = np.zeros((2, 9), bool)
    for k, off in enumerate(candidates):
        _, corners = pair_frames(*streams, offset_s=float(off))
        try:
            st = bundle_adjust(corners, config.board, list(intr), fixed, config.min_corners,
                               config.min_shared_views, config.robust_px, OFFSET_SEARCH_ITER)
        except CalibrationError:
            continue
        costs[k] = float(np.mean(st.rmse_px))
    if not np.isfinite(costs).any():
        msg = (f'offset: no candidate within +-{config.max_offset_s} s gives '
               f'{config.min_shared_views} frames seen by both cameras')
        raise CalibrationError(msg)
    offset, best = grid_minimum(np.asarray(candidates, np.float64), costs)
    LOG.info('front clock offset %.4f s (RMSE %.3f px at the best candidate)', offset,
             costs[best])
    return offset


def calibrate_detections(corners: FloatArray, stamps: FloatArray, config: CalibrationConfig,
                         intr: tuple[IntrinsicResult, ...] | None = None) -> CalibrationResult:
    """Calibrate both cameras from paired detections.

    Args:
        corners: (n_frames, 2, n_corners, 2) px, NaN where unseen; camera 0 side, 1 front.
        stamps: (n_frames,) frame times [s].
        config: settings.
        intr: per-camera intrinsic results if already computed (else from ``corners``).

    Raises:
        NotEnoughViewsError, DegenerateViewsError, CalibrationError.
    """
    board, size = config.board, config.image_size
    if intr is None:
        intr = tuple(calibrate_intrinsics(CAMERA_NAMES[c], corners[:, c], board, size,
                                          config.distortion, config.min_views,
                                          config.min_corners) for c in range(2))
    free = np.zeros((2, 9), bool)
    if config.refine_intrinsics:
        free[:, :4] = True
        free[:, 4:] = config.distortion.free
    st = bundle_adjust(corners, board, list(intr), free, config.min_corners,
                       config.min_shared_views, config.robust_px)
    world_frames, cams = _world_cameras(st, corners, config)
    calib = StereoCalibration(*cams, {})
    points = _point_set(st, corners, board, calib)
    report = _report(intr, st, calib, corners, board, world_frames, len(points))
    calib.info.update({k: report[k] for k in ('rmse_px', 'views', 'corner_spacing')})
    return CalibrationResult(calib, (intr[0], intr[1]), st, stamps, corners, world_frames, points,
                             report)


def _pose_matrix(rvec: FloatArray, tvec: FloatArray) -> tuple[FloatArray, FloatArray]:
    rot = np.asarray(cv2.Rodrigues(np.asarray(rvec, dtype=np.float64))[0], np.float64)
    return rot, np.asarray(tvec, np.float64)


def _world_cameras(st: StereoResult, corners: FloatArray, config: CalibrationConfig
                   ) -> tuple[NDArray[np.int64], tuple[CameraModel, CameraModel]]:
    """World frame from the first still board seen by both cameras (or the side camera)."""
    seen = ~np.isnan(corners[st.frames, :, :, 0])
    both = np.flatnonzero((seen.sum(2) >= config.min_corners).all(1))
    r_sw, t_sw = np.eye(3), np.zeros(3)  # world -> side camera
    world = np.zeros(0, np.int64)
    if config.world == 'surface':
        first = both[0] if len(both) else -1
        if first != 0:
            msg = (f'world frame: the first board view (t = {st.frames[0]}) is not seen by both '
                   'cameras; lay the board on the surface in view of both cameras at the start '
                   "of the recording, or use the 'side' world frame")
            raise CalibrationError(msg)
        r0, t0 = _pose_matrix(st.board_rvecs[first], st.board_tvecs[first])
        still = [first]
        for j in both[1:]:
            r, t = _pose_matrix(st.board_rvecs[j], st.board_tvecs[j])
            ang = np.degrees(np.linalg.norm(cv2.Rodrigues(r @ r0.T)[0]))
            if np.linalg.norm(t - t0) > STATIC_TOL_M or ang > STATIC_TOL_DEG or j != still[-1] + 1:
                break
            still.append(j)
        t_board = st.board_tvecs[still].mean(0)
        r_board = cv2.Rodrigues(st.board_rvecs[still].mean(0))[0]
        t_b0 = -SURFACE_ROT @ config.board.center_m  # board -> world of the surface pose
        r_sw = r_board @ SURFACE_ROT.T
        t_sw = t_board - r_sw @ t_b0
        world = st.frames[np.array(still)]
        LOG.info('world frame from %d still frames of the board on the surface', len(still))
    r_rel = cv2.Rodrigues(st.rel_rvec)[0]
    w, h = config.image_size
    cams = []
    for c, (r, t) in enumerate(((r_sw, t_sw), (r_rel @ r_sw, r_rel @ t_sw + st.rel_t))):
        k = st.intrinsics[c]
        kmat = np.array([[k[0], 0, k[2]], [0, k[1], k[3]], [0, 0, 1.0]])
        cams.append(CameraModel(CAMERA_NAMES[c], w, h, kmat, k[4:], r, t))
    return world.astype(np.int64), (cams[0], cams[1])


def _point_set(st: StereoResult, corners: FloatArray, board: BoardSpec,
               calib: StereoCalibration) -> PointSet:
    """Corners seen by both cameras in a frame, with world positions from the adjusted poses."""
    obj = board.object_points()
    r_ws, t_ws = calib.side.R.T, -calib.side.R.T @ calib.side.t  # side camera -> world
    pix, xyz, view, cid = [], [], [], []
    for j, i in enumerate(st.frames):
        both = np.flatnonzero(~np.isnan(corners[i, 0, :, 0]) & ~np.isnan(corners[i, 1, :, 0]))
        if len(both) == 0:
            continue
        r, t = _pose_matrix(st.board_rvecs[j], st.board_tvecs[j])
        pc = obj[both] @ r.T + t
        xyz.append(pc @ r_ws.T + t_ws)
        pix.append(np.hstack([corners[i, 0, both], corners[i, 1, both]]))
        view.append(np.full(len(both), i))
        cid.append(both)
    if not pix:
        return make_point_set(np.zeros((0, 4)), np.zeros((0, 3)), np.zeros(0), np.zeros(0))
    return make_point_set(np.concatenate(pix), np.concatenate(xyz), np.concatenate(view),
                          np.concatenate(cid))


def _report(intr: tuple[IntrinsicResult, ...], st: StereoResult, calib: StereoCalibration,
            corners: FloatArray, board: BoardSpec, world: NDArray[np.int64],
            n_points: int) -> dict[str, Any]:
    d = neighbour_distances(calib, corners, board)
    spacing = distance_summary(d, board.square_m) if len(d) else {}
    fr = st.frame_rmse_px
    return {
        'rmse_px': {'side': float(st.rmse_px[0]), 'front': float(st.rmse_px[1])},
        'intrinsic_rmse_px': {'side': intr[0].rmse_px, 'front': intr[1].rmse_px},
        'views': {'side': len(intr[0].views), 'front': len(intr[1].views),
                  'adjusted_frames': len(st.frames),
                  'shared': int(np.isfinite(fr).all(1).sum())},
        'view_rmse_px': {name: {'median': float(np.nanmedian(fr[:, c])),
                                'max': float(np.nanmax(fr[:, c]))}
                         for c, name in enumerate(('side', 'front'))},
        'world_frames': world.tolist(),
        'point_set_size': n_points,
        'corner_spacing': spacing,
        'board': {'kind': BoardKind(board.kind).value, 'columns': board.columns,
                  'rows': board.rows, 'square_m': board.square_m,
                  'dictionary': board.dictionary},
    }
