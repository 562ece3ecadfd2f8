"""Write the twin's calibration recording as a rosbag2 MCAP bag or as two videos.

The bag has both cameras' image topics (``dempath.topics``), as JPEG ``CompressedImage`` or
``mono8`` ``Image``; the truth (cameras, board, poses) goes to ``<bag>.truth.json`` beside it.
"""

from __future__ import annotations

import logging
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray
from rosbags.typesys import Stores, get_typestore

from dempath import topics
from dempath.bagio import write_bag
from dempath_calib.board import PAPER_BOARD, BoardSpec
from dempath_calib.camera import StereoCalibration
from dempath_twin.board.recording import (
    BoardPose,
    calibration_poses,
    render_views,
    save_truth,
    smooth_poses,
)
from dempath_twin.images import jpeg_message, stamp_header
from dempath_twin.rig import paper_rig

LOG = logging.getLogger(__name__)
JPEG_QUALITY = 92  # GoPro-like compression; corners stay within ~0.05 px


def truth_path(bag: str | Path) -> Path:
    """Where the truth JSON of a twin bag lives: ``<bag>.truth.json`` beside the bag folder."""
    bag = Path(bag)
    return bag.with_name(bag.name + '.truth.json')


def image_messages(image: NDArray[np.uint8], camera: str, stamp_ns: int,
                   compressed: bool, quality: int = JPEG_QUALITY) -> tuple[str, str, Any]:
    """``(topic, msgtype, rosbags message)`` of one grey image (Jazzy typestore)."""
    t = get_typestore(Stores.ROS2_JAZZY).types
    header = stamp_header(t, stamp_ns, f'{camera}_optical')
    if compressed:
        msg = jpeg_message(t, header, image, quality, 'mono8; jpeg compressed mono8')
        return (topics.camera_topic(topics.IMAGE_COMPRESSED, camera),
                'sensor_msgs/msg/CompressedImage', msg)
    h, w = image.shape
    msg = t['sensor_msgs/msg/Image'](header=header, height=h, width=w, encoding='mono8',
                                     is_bigendian=0, step=w, data=image.ravel())
    return topics.camera_topic(topics.IMAGE_RAW, camera), 'sensor_msgs/msg/Image', msg


def write_calibration_bag(path: str | Path, n_views: int = 40, seed: int = 0,
                          compressed: bool = True, period_s: float = 0.5,
                          front_delay_s: float = 0.0, rig: StereoCalibration | None = None,
                          board: BoardSpec = PAPER_BOARD, quality: int = JPEG_QUALITY) -> Path:
    """Render a twin calibration recording into a new bag and write its truth beside it.

    Args:
        path: bag folder to create.
        n_views: number of board poses (frames per camera).
        seed: random seed (poses and imaging conditions).
        compressed: JPEG CompressedImage (else raw mono8 Image).
        period_s: time between views [s].
        front_delay_s: added to the front camera's stamps (an unsynchronised clock) [s].
        rig: true cameras (``paper_rig()`` by default).
        board: the target.
        quality: JPEG quality (0-100).

    Returns:
        The bag folder.
    """
    rig = rig or paper_rig()
    poses = calibration_poses(n_views, seed, rig, board)
    write_bag(path, _messages(poses, seed, rig, board, compressed, period_s, front_delay_s,
                              quality))
    save_truth(truth_path(path), rig, board, poses)
    LOG.info('wrote %d views to %s', n_views, path)
    return Path(path)


def _messages(poses: list[BoardPose], seed: int, rig: StereoCalibration, board: BoardSpec,
              compressed: bool, period_s: float, front_delay_s: float,
              quality: int) -> Iterator[tuple[str, str, int, Any]]:
    for i, images in enumerate(render_views(poses, seed, rig, board)):
        for cam, image in enumerate(images):
            stamp = round((1.0 + i * period_s + (front_delay_s if cam else 0.0)) * 1e9)
            topic, msgtype, msg = image_messages(image, rig.cameras[cam].name, stamp,
                                                 compressed, quality)
            yield topic, msgtype, stamp, msg


def write_twin_videos(folder: str | Path, n_keys: int = 6, steps: int = 12, seed: int = 0,
                      front_delay_frames: int = 0, fps: float = 10.0,
                      scale: float = 0.5) -> tuple[Path, Path]:
    """Two MP4 videos of the board moving smoothly through the shared view.

    The front video starts ``front_delay_frames`` frames later than the side one (its frame 0
    shows the board where the side video's frame ``front_delay_frames`` does), so its true
    offset is ``+front_delay_frames / fps`` seconds. Frames are downscaled by ``scale``.

    Returns:
        (side, front) video paths.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    rig = paper_rig()
    keys = [p for p in calibration_poses(n_keys + 3, seed, rig, n_surface=3,
                                         shared_fraction=1.0) if p.phase == 'shared']
    poses = smooth_poses(keys, steps)
    paths = (folder / 'cam_side.mp4', folder / 'cam_front.mp4')
    size = (round(rig.side.width * scale), round(rig.side.height * scale))
    writers = [cv2.VideoWriter(str(p), cv2.VideoWriter.fourcc(*'mp4v'), fps, size)
               for p in paths]
    for i, images in enumerate(render_views(poses, seed, rig)):
        for cam, img in enumerate(images):
            if cam == 1 and i < front_delay_frames:
                continue
            small = cv2.resize(img, size, interpolation=cv2.INTER_AREA)
            writers[cam].write(cv2.cvtColor(small, cv2.COLOR_GRAY2BGR))
    for w in writers:
        w.release()
    return paths
