"""The detector nodes with ``lossless`` (bag playback): their numbered points do not depend on the
order the two cameras' images arrive in, and equal the offline ``track_bag`` on the same bag.

Real rclpy nodes through the harness, the bundled render's first 16 frames per camera, the twin's
true calibration. Two runs: the images published in stamp order, and every front image before
the first side image (the most the middleware could reorder two topics).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from builtin_interfaces.msg import Time
from rclpy.parameter import Parameter
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import CompressedImage
from std_msgs.msg import Header

from dempath import topics
from dempath.bagio import RawMessage, write_bag
from dempath_calib.camera import StereoCalibration
from dempath_msgs.msg import PixelPoints
from dempath_recon.nodes.detector import DetectorNode
from dempath_recon.tracking.stereo import StereoTrackConfig, track_bag

from .render_frames import field_images, stamp_ns

ROOT = Path(__file__).resolve().parents[1]
RENDER = ROOT / 'bags' / 'field_render_reduced_1ms'
TRUTH = RENDER.with_name(RENDER.name + '.truth.json')
FRAMES = 16  # per camera

RELIABLE = QoSProfile(history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE)
Points = dict[tuple[str, int], dict[int, tuple[float, float]]]  # (camera, stamp us) -> points


@pytest.fixture(scope='module')
def images() -> list[tuple[str, CompressedImage, RawMessage]]:
    """(camera, message, serialized message) of the render's first field frames, in bag
    order."""
    out: list[tuple[str, CompressedImage, RawMessage]] = []
    for cam, raw, msg in field_images(RENDER, FRAMES):
        header = Header(stamp=Time(sec=msg.header.stamp.sec, nanosec=msg.header.stamp.nanosec),
                        frame_id=msg.header.frame_id)
        out.append((cam, CompressedImage(header=header, format=msg.format,
                                         data=bytes(msg.data)), raw))
    return out


def run_nodes(ros_harness, calib: Path,
              order: list[tuple[str, CompressedImage, RawMessage]],
              whole_pass: bool = True) -> Points:
    """Both lossless detector nodes fed ``order`` (``whole_pass`` their parameter); their
    published points (the nodes are destroyed afterwards)."""
    nodes, got = {}, {}
    for cam in topics.CAMERAS:
        params = [Parameter('camera', value=cam), Parameter('lossless', value=True),
                  Parameter('calibration_file', value=str(calib)),
                  Parameter('merge_wait_s', value=5.0),  # a stalled test process is no end
                  Parameter('whole_pass', value=whole_pass)]
        nodes[cam] = ros_harness.add(DetectorNode(context=ros_harness.context, namespace=cam,
                                                  parameter_overrides=params))
        got[cam] = ros_harness.collect(PixelPoints,
                                       topics.camera_topic(topics.PIXEL_POINTS, cam), RELIABLE)
    pubs = {c: ros_harness.publisher(CompressedImage,
                                     topics.camera_topic(topics.IMAGE_COMPRESSED, c), RELIABLE)
            for c in topics.CAMERAS}
    assert all(ros_harness.wait_for_subscribers(p, count=2) for p in pubs.values())
    # each detector's points are read by the other detector and by this test: both matched
    # before the first image, or the first points can go out before this test's reader matched
    # (the fresh-clone CI once collected fewer than the 16 each detector published)
    assert all(ros_harness.wait_for_subscribers(n.pub, count=2) for n in nodes.values())
    for cam, msg, _ in order:
        pubs[cam].publish(msg)
        ros_harness.spin_for(0.01)
    assert ros_harness.spin_until(lambda: all(len(got[c]) == FRAMES for c in topics.CAMERAS),
                                  timeout_s=120.0), {c: n.figures() for c, n in nodes.items()}
    out: Points = {}
    for cam in topics.CAMERAS:
        for msg in got[cam]:
            out[(cam, round(stamp_ns(msg) / 1000))] = {int(m): (u, v) for m, u, v in zip(
                msg.marker_ids, msg.u, msg.v, strict=True)}
        ros_harness.executor.remove_node(nodes[cam])
        ros_harness.nodes.remove(nodes[cam])
        nodes[cam].destroy_node()
    return out


@pytest.mark.parametrize('whole_pass', [False, True])
def test_lossless_detectors_equal_track_bag_whatever_the_arrival_order(
        ros_harness, images: list[tuple[str, CompressedImage, RawMessage]],
        tmp_path: Path, whole_pass: bool) -> None:
    """Stamp order and front-before-side give the same numbered points, and those of
    ``track_bag`` (the same tracker, the same publication delay; with ``whole_pass`` every
    frame held till the end and the never-numbered tracks numbered from the whole pass) on a
    bag of the frames."""
    truth = json.loads(TRUTH.read_text())
    rig = StereoCalibration.from_dict(truth['calibration_segment']['rig'])
    calib = rig.save(tmp_path / 'calib.yaml')
    bag = tmp_path / 'frames'
    write_bag(bag, [(raw.topic, raw.msgtype, raw.log_time_ns, raw.data) for _, _, raw in images])
    frames, _ = track_bag(bag, {c.name: c for c in rig.cameras},
                          StereoTrackConfig(whole_pass=whole_pass))
    offline: Points = {(f.camera, round(f.stamp_s * 1e6)): {
        int(m): (float(p[0]), float(p[1])) for m, p in zip(f.markers, f.uv, strict=True)
        if m >= 0} for f in frames}
    in_order = run_nodes(ros_harness, calib, images, whole_pass)
    reordered = run_nodes(ros_harness, calib, [i for i in images if i[0] == 'cam_front']
                          + [i for i in images if i[0] == 'cam_side'], whole_pass)
    assert in_order.keys() == offline.keys()
    numbered = sum(len(p) for p in offline.values())
    assert numbered > 10 * FRAMES, numbered  # most markers numbered: the test is not empty
    for key, points in offline.items():
        assert in_order[key].keys() == points.keys() == reordered[key].keys(), key
        for m, uv in points.items():
            assert np.allclose(in_order[key][m], uv, atol=1e-4), (key, m)
            assert np.allclose(reordered[key][m], uv, atol=1e-4), (key, m)
