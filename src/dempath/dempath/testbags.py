"""Small seeded bags for tests and benchmarks (built in a temporary folder, never downloaded).

Each builder yields ``(topic, msgtype, t_ns, message)`` tuples for :func:`dempath.bagio.write_bag`
with rosbags message objects of the given typestore; stamps equal bag times.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numpy as np

from dempath import topics

START_NS = 1_700_000_000_000_000_000  # 2023-11-14T22:13:20Z


def header(store: Any, t_ns: int, frame_id: str) -> Any:
    """A ``std_msgs/Header`` with stamp ``t_ns`` [ns]."""
    time_t = store.types['builtin_interfaces/msg/Time']
    return store.types['std_msgs/msg/Header'](
        stamp=time_t(sec=t_ns // 10**9, nanosec=t_ns % 10**9), frame_id=frame_id)


def pixel_points(store: Any, count: int, period_ns: int = 20_000_000, n_markers: int = 15,
                 camera: str = 'cam_side', seed: int = 0,
                 start_ns: int = START_NS) -> Iterator[tuple[str, str, int, Any]]:
    """``count`` PixelPoints messages of ``n_markers`` random pixels every ``period_ns``."""
    rng = np.random.default_rng(seed)
    msg_t = store.types['dempath_msgs/msg/PixelPoints']
    topic = topics.camera_topic(topics.PIXEL_POINTS, camera)
    for i in range(count):
        t_ns = start_ns + i * period_ns
        yield topic, 'dempath_msgs/msg/PixelPoints', t_ns, msg_t(
            header=header(store, t_ns, camera),
            marker_ids=np.arange(1, n_markers + 1, dtype=np.int32),
            u=rng.uniform(0, 1920, n_markers), v=rng.uniform(0, 1080, n_markers),
            confidence=rng.uniform(0, 1, n_markers).astype(np.float32),
            source=rng.integers(0, 2, n_markers).astype(np.uint8))


def images(store: Any, count: int, width: int, height: int, period_ns: int = 20_000_000,
           camera: str = 'cam_side', jpeg: bool = False, seed: int = 0,
           start_ns: int = START_NS) -> Iterator[tuple[str, str, int, Any]]:
    """``count`` seeded frames: ``sensor_msgs/Image`` bgr8 or JPEG ``CompressedImage``.

    The frames are a smooth random gradient with a moving bright square, so that JPEG sizes
    stay realistic (tens to hundreds of kB at 1920x1080).
    """
    import cv2

    rng = np.random.default_rng(seed)
    low = cv2.resize(rng.integers(0, 255, (9, 16, 3), dtype=np.uint8), (width, height))
    for i in range(count):
        t_ns = start_ns + i * period_ns
        frame = low.copy()
        x = (i * 37) % max(1, width - 64)
        frame[height // 3:height // 3 + 64, x:x + 64] = 255
        hdr = header(store, t_ns, camera)
        if jpeg:
            ok, data = cv2.imencode('.jpg', frame, [cv2.IMWRITE_JPEG_QUALITY, 90])
            assert ok, 'JPEG encoding failed'
            msg = store.types['sensor_msgs/msg/CompressedImage'](
                header=hdr, format='jpeg', data=data.reshape(-1))
            yield (topics.camera_topic(topics.IMAGE_COMPRESSED, camera),
                   'sensor_msgs/msg/CompressedImage', t_ns, msg)
        else:
            msg = store.types['sensor_msgs/msg/Image'](
                header=hdr, height=height, width=width, encoding='bgr8', is_bigendian=0,
                step=width * 3, data=frame.reshape(-1))
            yield (topics.camera_topic(topics.IMAGE_RAW, camera), 'sensor_msgs/msg/Image',
                   t_ns, msg)
