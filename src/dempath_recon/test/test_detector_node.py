"""The detection node, launch-free: real rclpy pub/sub through the ros_harness."""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray
from sensor_msgs.msg import CompressedImage

sys.path.insert(0, str(Path(__file__).parent))
from spots import spot_image

from dempath import topics
from dempath_calib.camera import StereoCalibration
from dempath_msgs.msg import PixelPoints
from dempath_recon.errors import ReconstructionError
from dempath_recon.nodes.detector import DetectorNode
from dempath_recon.tracking.associate import MarkerGrid


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
    assert node.handled_frames() == 3  # the demo waits for this count; the corrupt one is in it


def test_detector_node_numbers_the_grid_of_its_scene(ros_harness, rig, tmp_path) -> None:
    """``scene:=tiny`` (3 x 5 markers 25 mm apart, half the paper's pitch): the front camera's
    node numbers all 15 markers, each with its own number."""
    calib = StereoCalibration(rig.side, rig.front, {})
    node = ros_harness.start(DetectorNode, camera='cam_front', scene='tiny',
                             calibration_file=str(calib.save(tmp_path / 'calib.yaml')))
    assert node.core.config.grid == MarkerGrid(spacing_x_m=0.025, spacing_z_m=0.025)
    got = ros_harness.collect(PixelPoints, topics.camera_topic(topics.PIXEL_POINTS, 'cam_front'))
    pub = ros_harness.publisher(CompressedImage,
                                topics.camera_topic(topics.IMAGE_COMPRESSED, 'cam_front'))
    assert ros_harness.wait_for_subscribers(pub)
    numbers, xyz = node.core.config.grid.points()
    uv = rig.front.project(xyz)
    data = spot_image((rig.front.height, rig.front.width), uv, 3.0, np.random.default_rng(1),
                      quality=92)
    for k in range(2):
        pub.publish(jpeg_msg(data, 1_000_000_000 + 20_000_000 * k))
        ros_harness.spin_until(lambda: False, timeout_s=0.05)
    assert ros_harness.spin_until(lambda: len(got) == 2, timeout_s=20), len(got)
    for msg in got:
        assert sorted(msg.marker_ids) == list(numbers), msg.marker_ids
        for m, u, v in zip(msg.marker_ids, msg.u, msg.v, strict=True):
            assert np.hypot(u - uv[m - 1, 0], v - uv[m - 1, 1]) < 1.0, (m, u, v)


def test_detector_node_grid_parameters(ros_harness, rig, tmp_path) -> None:
    """The marker_* parameters give the grid; a scene that does not exist is refused by name."""
    calib = str(StereoCalibration(rig.side, rig.front, {}).save(tmp_path / 'calib.yaml'))
    node = ros_harness.start(DetectorNode, camera='cam_side', calibration_file=calib,
                             marker_rows=2, marker_columns=4, marker_spacing_x_m=0.03,
                             marker_spacing_z_m=0.04, marker_side=-1)
    assert node.core.config.grid == MarkerGrid(2, 4, 0.03, 0.04, -1)
    with pytest.raises(ReconstructionError, match='no_such_scene'):
        MarkerGrid.from_scene('no_such_scene')


def test_detector_node_marker_colour_parameter(ros_harness, rig, tmp_path) -> None:
    """``marker_bgr`` sets the detector's clay colour ('' keeps blue clay); a bad colour is one
    ReconstructionError naming the parameter."""
    calib = str(StereoCalibration(rig.side, rig.front, {}).save(tmp_path / 'calib.yaml'))
    node = ros_harness.start(DetectorNode, camera='cam_side', calibration_file=calib,
                             marker_bgr='0.15,0.18,0.62')
    assert node.core.detectors['cam_side'].config.marker_bgr == (0.15, 0.18, 0.62)
    blue = ros_harness.start(DetectorNode, camera='cam_side', calibration_file=calib)
    assert blue.core.detectors['cam_side'].config.marker_bgr is None
    with pytest.raises(ReconstructionError, match='marker_bgr'):
        ros_harness.start(DetectorNode, camera='cam_side', calibration_file=calib,
                          marker_bgr='red')


def test_detector_node_tool_speed_parameter(ros_harness, rig, tmp_path) -> None:
    """``tool_speed_m_s`` gives each camera's linker its speed bound (0, the default: none); a
    negative speed is one ReconstructionError naming the parameter."""
    calib = str(StereoCalibration(rig.side, rig.front, {}).save(tmp_path / 'calib.yaml'))
    node = ros_harness.start(DetectorNode, camera='cam_side', calibration_file=calib,
                             tool_speed_m_s=0.5)
    assert node.core.config.tool_speed_m_s == 0.5
    assert node.core.state.trackers['cam_side'].config.max_image_speed_px_s > 0
    plain = ros_harness.start(DetectorNode, camera='cam_side', calibration_file=calib)
    assert plain.core.state.trackers['cam_side'].config.max_image_speed_px_s == 0
    with pytest.raises(ReconstructionError, match='tool_speed_m_s'):
        ros_harness.start(DetectorNode, camera='cam_side', calibration_file=calib,
                          tool_speed_m_s=-1.0)
