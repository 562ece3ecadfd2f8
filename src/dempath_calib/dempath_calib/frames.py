"""The cameras of a calibration as TF frames (:mod:`dempath.frames`).

A calibration's world is the measurement's ``field`` frame (the board on the sand: X lateral,
Y up, Z travel, origin at the board centre); each camera's optical frame (OpenCV's camera frame,
REP 103's ``_optical``: z forward, x right, y down) sits at ``-R^T t`` with axes ``R^T``.
"""

from __future__ import annotations

from dempath.frames import FIELD, Transform, camera_transform
from dempath_calib.camera import StereoCalibration


def camera_frames(calibration: StereoCalibration, parent: str = FIELD) -> list[Transform]:
    """``parent`` -> ``<camera>_optical`` for both cameras of ``calibration``."""
    return [camera_transform(cam.name, cam.R, cam.t, parent) for cam in calibration.cameras]
