"""Check calibrations on a recording: read them, pair the frames truly, measure both checks.

``load_calibration`` reads a dempath calibration folder or ``stereo.yaml``, or Caliscope's
``camera_array.toml`` (its first two cameras as side and front); ``check_calibrations`` pairs the
two cameras' detections at a clock offset (given, or ``syncmotion.motion_offset`` from the
board's motion) with the front corners interpolated to the side camera's instants, and returns
``rigidity.board_rigidity`` and ``rigidity.epipolar_errors`` of each calibration on the same
frames.
"""

from __future__ import annotations

import tomllib
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from dempath_calib.board import BoardSpec, CornerDetector
from dempath_calib.camera import CameraModel, StereoCalibration
from dempath_calib.errors import CalibrationError, CalibrationFileError
from dempath_calib.intrinsics import IntrinsicResult
from dempath_calib.pairing import DetectionStream, pair_frames
from dempath_calib.rigidity import (
    MIN_CORNERS,
    RigidityResult,
    board_rigidity,
    frame_epipolar_errors,
)
from dempath_calib.sources import Frame
from dempath_calib.stereo import bundle_adjust
from dempath_calib.syncmotion import MotionOffset, board_trajectory, motion_offset

FloatArray = NDArray[np.float64]


def load_caliscope(path: Path) -> StereoCalibration:
    """Caliscope's ``camera_array.toml``: the two lowest camera ids as side and front.

    Caliscope stores per camera ``size``, ``matrix`` (3x3), ``distortions`` (k1 k2 p1 p2 k3),
    ``rotation`` (3x3) and ``translation`` (m), world to camera, as dempath does.
    """
    try:
        cams = tomllib.loads(path.read_text())['cameras']
        ids = sorted(cams, key=int)[:2]
        models = [CameraModel(f'cam_{i}', int(cams[i]['size'][0]), int(cams[i]['size'][1]),
                              np.array(cams[i]['matrix']), np.array(cams[i]['distortions']),
                              np.array(cams[i]['rotation']), np.array(cams[i]['translation']))
                  for i in ids]
        if len(models) < 2:
            msg = f'{str(path)!r}: Caliscope camera array with {len(models)} camera, need 2'
            raise CalibrationFileError(msg)
    except (OSError, tomllib.TOMLDecodeError, KeyError, TypeError, ValueError) as err:
        msg = f'{str(path)!r}: not a Caliscope camera array ({type(err).__name__}: {err})'
        raise CalibrationFileError(msg) from err
    return StereoCalibration(models[0], models[1], {'source': 'caliscope'})


def load_calibration(path: str | Path) -> StereoCalibration:
    """A dempath calibration folder or stereo YAML, or Caliscope's camera_array.toml.

    Raises:
        CalibrationFileError: missing or unreadable file.
    """
    path = Path(path)
    if path.is_dir():
        path = path / 'stereo.yaml'
    if path.suffix == '.toml':
        return load_caliscope(path)
    return StereoCalibration.load(path)


@dataclass(frozen=True)
class CalibrationCheck:
    """Both checks of one calibration on the paired frames.

    Attributes:
        name: label of the calibration (its path).
        rigidity: all corner-pair distances against the printed board.
        epipolar_px: symmetric epipolar error of every corner pair [px].
    """

    name: str
    rigidity: RigidityResult
    epipolar_px: FloatArray

    def summary(self) -> dict[str, Any]:
        """JSON-ready figures."""
        e = self.epipolar_px
        epi = ({'n': len(e), 'mean_px': float(e.mean()), 'rms_px': float(np.sqrt(np.mean(e ** 2))),
                'max_px': float(e.max())} if len(e) else {'n': 0})
        return {'name': self.name, 'rigidity': self.rigidity.summary(), 'epipolar': epi,
                'by_separation': [b.__dict__ for b in self.rigidity.bins]}


def pair_streams(streams: tuple[DetectionStream, DetectionStream],
                 offset_s: float) -> FloatArray:
    """(n, 2, n_corners, 2) px: front corners interpolated to the side frames' instants."""
    return pair_frames(*streams, offset_s=offset_s, interpolate=True)[1]


def estimate_offset(streams: tuple[DetectionStream, DetectionStream], calib: StereoCalibration,
                    board: BoardSpec, max_offset_s: float) -> MotionOffset:
    """``motion_offset`` of the front camera with ``calib``'s intrinsics (not its poses)."""
    (ts, cs), (tf, cf) = streams[0].arrays(), streams[1].arrays()
    if len(ts) < 3 or len(tf) < 3:
        msg = f'offset: {len(ts)} side and {len(tf)} front board views, need 3 each'
        raise CalibrationError(msg)
    return motion_offset(ts, board_trajectory(cs, calib.side, board), tf,
                         board_trajectory(cf, calib.front, board), max_offset_s)


def detect_streams(frames: Iterable[Frame], board: BoardSpec,
                   min_corners: int = MIN_CORNERS) -> tuple[DetectionStream, DetectionStream]:
    """Both cameras' board detections with at least ``min_corners`` corners, by camera."""
    detector = CornerDetector(board)
    streams = (DetectionStream(board.n_corners), DetectionStream(board.n_corners))
    for cam, stamp, image in frames:
        corners = detector.detect(image)
        if np.isfinite(corners[:, 0]).sum() >= min_corners:
            streams[cam].add(stamp, corners)
    return streams


def refit_relative_pose(calib: StereoCalibration, corners: FloatArray, board: BoardSpec,
                        min_corners: int = 6) -> StereoCalibration:
    """``calib``'s intrinsics kept, the front camera's pose re-estimated from ``corners``.

    A bundle adjustment (``stereo.bundle_adjust``) with every intrinsic fixed; the result is in
    the side camera's frame. Tells whether a calibration's relative pose or its intrinsics make
    it fail the checks.
    """
    intr = [IntrinsicResult(c.K, c.dist, float('nan'), np.zeros(0), np.zeros(0, np.int64),
                            np.zeros((0, 3)), np.zeros((0, 3))) for c in calib.cameras]
    st = bundle_adjust(corners, board, intr, np.zeros((2, 9), bool), min_corners)
    rot = np.asarray(cv2.Rodrigues(st.rel_rvec)[0], np.float64)
    return StereoCalibration(calib.side.with_pose(np.eye(3), np.zeros(3)),
                             calib.front.with_pose(rot, st.rel_t),
                             {'rmse_px': st.rmse_px.tolist()})


def check_calibrations(calibs: dict[str, StereoCalibration], corners: FloatArray,
                       board: BoardSpec) -> list[CalibrationCheck]:
    """Rigidity and epipolar error of each calibration on the same simultaneous frames."""
    return [CalibrationCheck(name, board_rigidity(c, corners, board),
                             frame_epipolar_errors(c, corners)) for name, c in calibs.items()]
