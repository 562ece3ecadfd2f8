"""Message <-> numpy for the calibration node."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray
from sensor_msgs.msg import CameraInfo, CompressedImage

from dempath_calib.camera import CameraModel
from dempath_calib.sources import decode_image


def image_to_grey(msg: Any, where: str) -> tuple[float, NDArray[np.uint8]]:
    """(stamp [s], grey image (h, w) uint8) of a sensor_msgs Image or CompressedImage."""
    kind = 'CompressedImage' if isinstance(msg, CompressedImage) else 'Image'
    stamp = msg.header.stamp.sec + 1e-9 * msg.header.stamp.nanosec
    return stamp, decode_image(kind, msg, where)


def camera_info_msg(camera: CameraModel, frame_id: str) -> CameraInfo:
    """sensor_msgs/CameraInfo of a calibrated camera (plumb_bob, R = I, P = [K | 0])."""
    msg = CameraInfo()
    msg.header.frame_id = frame_id
    msg.width, msg.height = int(camera.width), int(camera.height)
    msg.distortion_model = 'plumb_bob'
    msg.d = [float(v) for v in camera.dist]
    msg.k = [float(v) for v in camera.K.ravel()]
    msg.r = [float(v) for v in np.eye(3).ravel()]
    msg.p = [float(v) for v in np.hstack([camera.K, np.zeros((3, 1))]).ravel()]
    return msg
