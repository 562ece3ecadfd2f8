"""A detector node says on ``/diagnostics`` when the cameras seem to have moved since the
calibration: the bundled render's frames shaken by up to 3 px a frame (``shake_3px`` of the
field-condition set), the calibration unchanged, through a real lossless detector node with the
shake correction off (what is left when the image's motion cannot be estimated)."""

from __future__ import annotations

import json
from pathlib import Path

from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from rclpy.parameter import Parameter
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import CompressedImage

from dempath import topics
from dempath_calib.camera import StereoCalibration
from dempath_msgs.msg import PixelPoints
from dempath_recon.nodes.detector import DetectorNode
from dempath_twin.render.conditions import Condition, vary_recording

from .render_frames import field_images, stamp_ns

ROOT = Path(__file__).resolve().parents[1]
RENDER = ROOT / 'bags' / 'field_render_reduced_1ms'
FRAMES = 16  # per camera: the drift check needs 10 checked frames
RELIABLE = QoSProfile(history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE)


def shaken_frames(truth: dict) -> list[tuple[str, int, bytes]]:
    """(camera, stamp ns, JPEG) of the first field frames, each image moved by up to 3 px."""
    frames = [(cam, stamp_ns(msg), bytes(msg.data))
              for cam, _, msg in field_images(RENDER, FRAMES)]
    return vary_recording(frames, truth, Condition('shake_3px', shake_px=3.0, seed=9))[0]


def test_shaken_cameras_make_the_detector_warn(ros_harness, tmp_path: Path) -> None:
    """Pairs 2-3 px off their epipolar lines for 10 frames: ``drift_frames`` counted and the
    node's status WARN, its message naming the epipolar lines."""
    truth = json.loads(RENDER.with_name(RENDER.name + '.truth.json').read_text())
    calib = StereoCalibration.from_dict(truth['calibration_segment']['rig']).save(
        tmp_path / 'calib.yaml')
    params = [Parameter('camera', value='cam_side'), Parameter('lossless', value=True),
              Parameter('calibration_file', value=str(calib)),
              Parameter('correct_shake', value=False),
              Parameter('diagnostics_period_s', value=0.2), Parameter('merge_wait_s', value=5.0)]
    node = ros_harness.add(DetectorNode(context=ros_harness.context, namespace='cam_side',
                                        parameter_overrides=params))
    got = ros_harness.collect(PixelPoints, topics.camera_topic(topics.PIXEL_POINTS, 'cam_side'),
                              RELIABLE)
    diag = ros_harness.collect(DiagnosticArray, '/diagnostics')
    pubs = {c: ros_harness.publisher(CompressedImage,
                                     topics.camera_topic(topics.IMAGE_COMPRESSED, c), RELIABLE)
            for c in topics.CAMERAS}
    assert all(ros_harness.wait_for_subscribers(p) for p in pubs.values())
    for cam, stamp, data in sorted(shaken_frames(truth), key=lambda f: f[1]):
        msg = CompressedImage(format='jpeg', data=data)
        msg.header.stamp = Time(sec=stamp // 10**9, nanosec=stamp % 10**9)
        pubs[cam].publish(msg)
        ros_harness.spin_for(0.01)
    assert ros_harness.spin_until(lambda: len(got) == FRAMES, timeout_s=60.0), len(got)
    assert node.figures()['drift_frames'] > 0, node.figures()

    def warned() -> bool:
        return any(s.level == DiagnosticStatus.WARN and 'epipolar lines' in s.message
                   for d in diag for s in d.status)

    assert ros_harness.spin_until(warned, timeout_s=10.0), [s.message for d in diag
                                                            for s in d.status]
