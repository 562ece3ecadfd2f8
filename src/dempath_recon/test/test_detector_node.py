"""The detection node, launch-free: real rclpy pub/sub through the ros_harness."""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray
from sensor_msgs.msg import CompressedImage

sys.path.insert(0, str(Path(__file__).parent))
from spots import spot_image

from dempath import topics
from dempath_calib.camera import StereoCalibration
from dempath_msgs.msg import PixelPoints
from dempath_recon.associate import MarkerGrid
from dempath_recon.nodes.detector import DetectorNode


def half(cam):
    """The camera with a 960 x 540 sensor."""
    k = cam.K.copy()
    k[:2] *= 0.5
    k[:2, 2] = (cam.K[:2, 2] + 0.5) * 0.5 - 0.5
    return replace(cam, width=cam.width // 2, height=cam.height // 2, K=k)


def jpeg_msg(data: bytes, stamp_ns: int) -> CompressedImage:
    """A CompressedImage of JPEG bytes."""
    msg = CompressedImage(format='jpeg', data=data)
    msg.header.stamp = Time(sec=stamp_ns // 10**9, nanosec=stamp_ns % 10**9)
    return msg


def test_detector_node_publishes_numbered_points_and_counts(ros_harness, rig, tmp_path) -> None:
    """Three frames (one corrupt): 15 numbered SOURCE_DETECTED points, counts in diagnostics."""
    side = half(rig.side)
    calib = StereoCalibration(side, half(rig.front), {})
    node = ros_harness.start(DetectorNode, camera='cam_side', diagnostics_period_s=0.2,
                             calibration_file=str(calib.save(tmp_path / 'calib.yaml')))
    got = ros_harness.collect(PixelPoints, topics.camera_topic(topics.PIXEL_POINTS, 'cam_side'))
    diag = ros_harness.collect(DiagnosticArray, '/diagnostics')
    pub = ros_harness.publisher(CompressedImage,
                                topics.camera_topic(topics.IMAGE_COMPRESSED, 'cam_side'))
    assert ros_harness.wait_for_subscribers(pub)
    numbers, xyz = MarkerGrid().points()
    rng = np.random.default_rng(0)
    truth = []
    for k in range(3):
        uv = side.project(xyz + np.array([0.0, 0.0, 0.003 * k]))
        truth.append(uv)
        data = spot_image((side.height, side.width), uv, 3.0, rng, quality=92)
        pub.publish(jpeg_msg(data[:300] if k == 1 else data, 1_000_000_000 + 20_000_000 * k))
        ros_harness.spin_until(lambda: False, timeout_s=0.05)
    assert ros_harness.spin_until(lambda: len(got) == 3, timeout_s=20), len(got)
    assert ros_harness.spin_until(
        lambda: any(kv.key == 'undecodable' and kv.value == '1'
                    for d in diag for s in d.status for kv in s.values), timeout_s=10)
    for k in (0, 2):
        msg = got[k]
        assert sorted(msg.marker_ids) == list(numbers)
        assert set(msg.source) == {PixelPoints.SOURCE_DETECTED}
        assert all(0 <= c <= 1 for c in msg.confidence)
        uv = np.column_stack([msg.u, msg.v])[np.argsort(msg.marker_ids)]
        assert np.abs(uv - truth[k]).max() < 0.6
    assert len(got[1].marker_ids) == 0
    assert node.core.report()['cam_side']['undecodable'] == 1
