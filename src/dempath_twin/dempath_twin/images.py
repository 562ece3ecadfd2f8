"""Image messages of the synthetic recordings: stamped headers and JPEG CompressedImage.

The calibration bag (``board.bag``) and the field twins (``field``, ``render``) write camera
images the same way; this is that one way. Messages are rosbags objects built from a
typestore's ``types``.
"""

from __future__ import annotations

from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from dempath_twin.errors import TwinError


def stamp_header(types: Any, stamp_ns: int, frame_id: str) -> Any:
    """``std_msgs/Header`` at ``stamp_ns`` [ns since the epoch] in ``frame_id``."""
    time = types['builtin_interfaces/msg/Time'](sec=stamp_ns // 10**9, nanosec=stamp_ns % 10**9)
    return types['std_msgs/msg/Header'](stamp=time, frame_id=frame_id)


def encode_jpeg(image: NDArray[np.uint8], quality: int) -> NDArray[np.uint8]:
    """JPEG bytes of ``image`` (grey or BGR) as a flat uint8 array."""
    ok, data = cv2.imencode('.jpg', image, [cv2.IMWRITE_JPEG_QUALITY, int(quality)])
    if not ok:
        msg = f'image {image.shape}: JPEG encoding failed'
        raise TwinError(msg)
    return np.asarray(data, dtype=np.uint8).ravel()


def jpeg_message(types: Any, header: Any, image: NDArray[np.uint8], quality: int,
                 fmt: str) -> Any:
    """``sensor_msgs/CompressedImage`` of ``image`` with ``format`` ``fmt``."""
    return types['sensor_msgs/msg/CompressedImage'](header=header, format=fmt,
                                                     data=encode_jpeg(image, quality))
