"""The calibration node, launch-free: images in, Trigger, latched CameraInfo and files out."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import CameraInfo, CompressedImage, Image
from std_srvs.srv import Trigger

from dempath import topics
from dempath_calib.nodes.calibrator import CalibratorNode
from dempath_twin.board.recording import calibration_poses, render_views
from dempath_twin.rig import paper_rig

pytestmark = pytest.mark.usefixtures('strict_numpy')  # as the dempath_calib tests ran

N_VIEWS = 16
K_REL_TOL = 0.01  # fx, fy within 1% with this few views


def _compressed(image: np.ndarray, stamp_s: float) -> CompressedImage:
    msg = CompressedImage()
    msg.header.stamp.sec = int(stamp_s)
    msg.header.stamp.nanosec = round((stamp_s % 1) * 1e9)
    msg.format = 'jpeg'
    msg.data = cv2.imencode('.jpg', image, [cv2.IMWRITE_JPEG_QUALITY, 95])[1].tobytes()
    return msg


def _call(harness: Any, client: Any) -> Any:
    assert client.wait_for_service(timeout_sec=10.0)
    future = client.call_async(Trigger.Request())
    assert harness.spin_until(future.done, timeout_s=120.0), 'solve did not answer'
    return future.result()


def test_node_calibrates_from_image_topics(ros_harness: Any, tmp_path: Path) -> None:
    """Too early a solve fails with a reason; after 16 views CameraInfo is latched and right."""
    node = ros_harness.start(CalibratorNode, min_views=6, output_dir=str(tmp_path / 'out'))
    client = ros_harness.probe.create_client(Trigger, '/dempath_calibrator/solve')
    early = _call(ros_harness, client)
    assert not early.success and 'need 6' in early.message
    pubs = [ros_harness.publisher(CompressedImage, topics.camera_topic(topics.IMAGE_COMPRESSED,
                                                                       cam))
            for cam in topics.CAMERAS]
    for pub in pubs:
        assert ros_harness.wait_for_subscribers(pub)
    for i, images in enumerate(render_views(calibration_poses(N_VIEWS, seed=11), seed=11)):
        for pub, image in zip(pubs, images, strict=True):
            pub.publish(_compressed(image, 10.0 + 0.5 * i))
        frames = node.collector.calibrator.progress().frames
        assert ros_harness.spin_until(
            lambda n=i + 1: (node.collector.calibrator.progress().frames[0]
                             + node.collector.dropped[0]) >= n
            and (node.collector.calibrator.progress().frames[1]
                 + node.collector.dropped[1]) >= n, timeout_s=30.0), frames
    answer = _call(ros_harness, client)
    assert answer.success, answer.message
    latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                         reliability=ReliabilityPolicy.RELIABLE)
    got = {cam: ros_harness.collect(CameraInfo, topics.camera_topic(topics.CAMERA_INFO, cam),
                                    latched) for cam in topics.CAMERAS}
    assert ros_harness.spin_until(lambda: all(got.values()), timeout_s=10.0)
    for cam, true in zip(topics.CAMERAS, paper_rig().cameras, strict=True):
        k = np.array(got[cam][0].k).reshape(3, 3)
        assert abs(k[0, 0] / true.K[0, 0] - 1) < K_REL_TOL
        assert abs(k[1, 1] / true.K[1, 1] - 1) < K_REL_TOL
        assert got[cam][0].distortion_model == 'plumb_bob'
    for name in ('cam_side.yaml', 'cam_front.yaml', 'stereo.yaml', 'point_set.npz'):
        assert (tmp_path / 'out' / name).is_file()


def test_node_idle_solve_reports_missing_views(ros_harness: Any) -> None:
    """Raw images without a board, then silence: the idle solve fails with a counted reason."""
    node = ros_harness.start(CalibratorNode, compressed=False, solve_after_idle_s=0.5,
                             image_width=640, image_height=360)
    pubs = [ros_harness.publisher(Image, topics.camera_topic(topics.IMAGE_RAW, cam))
            for cam in topics.CAMERAS]
    for pub in pubs:
        assert ros_harness.wait_for_subscribers(pub)
    blank = Image(height=360, width=640, encoding='mono8', step=640, data=bytes(640 * 360))
    for pub in pubs:
        pub.publish(blank)
    progress = node.collector.calibrator.progress
    assert ros_harness.spin_until(lambda: progress().frames == (1, 1), timeout_s=10.0)
    assert ros_harness.spin_until(lambda: 'need 8' in node._error, timeout_s=10.0)
    assert node.result is None and progress().skipped == (1, 1)
