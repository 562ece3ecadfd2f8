"""The reconstruction node, launch-free: real rclpy pub/sub through the ros_harness."""

from __future__ import annotations

import numpy as np
import pytest
from builtin_interfaces.msg import Time
from visualization_msgs.msg import MarkerArray

from dempath import topics
from dempath.nodes.harness import unique_domain_id
from dempath_msgs.msg import MarkerPoints3D, PixelPoints
from dempath_recon.errors import ModelFileError
from dempath_recon.nodes.reconstructor import ReconstructorNode, main
from dempath_recon.stream import REASON_NAN, REASON_OUTSIDE
from dempath_twin.rig import sample_working_volume


def pixel_msg(cam, stamp_ns: int, ids: list[int], uv: np.ndarray) -> PixelPoints:
    """A PixelPoints message of one camera."""
    msg = PixelPoints()
    msg.header.stamp = Time(sec=stamp_ns // 10**9, nanosec=stamp_ns % 10**9)
    msg.header.frame_id = cam.name
    msg.marker_ids = ids
    msg.u, msg.v = uv[:, 0].tolist(), uv[:, 1].tolist()
    msg.confidence = [1.0] * len(ids)
    msg.source = [PixelPoints.SOURCE_CLICKED] * len(ids)
    return msg


def test_node_publishes_points_sigma_and_markers(ros_harness, rig, tmp_path) -> None:
    """3 instants x 4 markers: exact 3D points, sigma, MarkerArray; bad points counted."""
    node = ros_harness.start(ReconstructorNode, method='dlt_refined', slop=0.005,
                             calibration_file=str(rig.save(tmp_path / 'calib.yaml')))
    got = ros_harness.collect(MarkerPoints3D, topics.MARKER_POINTS)
    viz = ros_harness.collect(MarkerArray, topics.MARKER_VIZ)
    pubs = [ros_harness.publisher(PixelPoints, topics.camera_topic(topics.PIXEL_POINTS, c))
            for c in topics.CAMERAS]
    for pub in pubs:
        assert ros_harness.wait_for_subscribers(pub)
    truth = sample_working_volume(12, np.random.default_rng(4)).reshape(3, 4, 3)
    for k in range(3):
        for pub, cam, offset in zip(pubs, rig.cameras, (0, 2_000_000), strict=True):
            uv = cam.project(truth[k])
            if k == 1 and cam.name == 'cam_front':
                uv[3] = (np.nan, 10.0)
                uv[2] = (10.0, -5.0)
            pub.publish(pixel_msg(cam, 1_000_000_000 + 20_000_000 * k + offset,
                                  [11, 12, 13, 14], uv))
            ros_harness.spin_until(lambda: False, timeout_s=0.05)
    assert ros_harness.spin_until(lambda: len(got) == 3 and len(viz) == 3), (len(got), len(viz))
    for k, msg in enumerate(got):
        xyz = np.column_stack([msg.x, msg.y, msg.z])
        n = 2 if k == 1 else 4
        assert list(msg.marker_ids) == [11, 12, 13, 14][:n]
        assert np.abs(xyz - truth[k][:n]).max() < 1e-9
        assert msg.method == 'dlt_refined' and msg.header.frame_id == 'field'
        assert all(0 < s < 0.01 for s in [*msg.sigma_x, *msg.sigma_y, *msg.sigma_z])
        assert len(viz[k].markers) == n
    assert node.stream.rejected == {REASON_NAN: 1, REASON_OUTSIDE[1]: 1}


def test_node_refuses_a_missing_calibration(ros_harness, tmp_path) -> None:
    """A missing calibration file stops the node with ModelFileError naming the file."""
    with pytest.raises(ModelFileError, match=r'nowhere\.yaml'):
        ros_harness.start(ReconstructorNode, calibration_file=str(tmp_path / 'nowhere.yaml'))


def test_main_prints_one_error_line(tmp_path, capsys, monkeypatch) -> None:
    """The console script prints one 'error:' line and returns 1 on a corrupt model file."""
    monkeypatch.setenv('ROS_DOMAIN_ID', str(unique_domain_id()))
    bad = tmp_path / 'model.pt'
    bad.write_bytes(b'garbage')
    code = main(['--ros-args', '-p', 'method:=mlp', '-p', f'model_file:={bad}'])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1
    assert len(err) == 1 and err[0].startswith('error: ') and 'model.pt' in err[0]
