"""Marker detection node, one per camera: images -> numbered dempath_msgs/PixelPoints.

Subscribes ``/<camera>/image_raw/compressed`` (``sensor_msgs/CompressedImage``, or
``/<camera>/image_raw`` ``sensor_msgs/Image`` bgr8/rgb8 with ``compressed:=false``) and the other
camera's ``pixel_points`` (for numbering markers by the epipolar line), and publishes
``/<camera>/pixel_points`` with ``SOURCE_DETECTED`` and the detector's confidence; only numbered
markers are published (the reconstructor pairs by number). Counts (frames, detected, tracked,
lost, re-attached, dropped, undecodable, out of order) go out as ``diagnostic_msgs`` on
``/diagnostics`` every ``diagnostics_period_s``. Every frame is processed in the callback (no
queue drops); a bad frame is counted and logged, and the node keeps spinning.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.node import Node
from sensor_msgs.msg import CompressedImage, Image

from dempath import topics
from dempath.nodes.spin import run_node
from dempath_msgs.msg import PixelPoints
from dempath_recon.errors import ReconstructionError
from dempath_recon.stereo_track import PixelFrame, StereoMarkerTracker

PARAMETERS: tuple[tuple[str, Any, str], ...] = (
    ('camera', 'cam_side', 'camera whose images this node detects in (cam_side, cam_front)'),
    ('calibration_file', '', 'stereo calibration YAML (dempath_calib) [path], required'),
    ('compressed', True, 'subscribe CompressedImage (true) or Image (false)'),
    ('diagnostics_period_s', 1.0, 'period of the diagnostics message [s]'),
)


class DetectorNode(Node):
    """Thin adapter around :class:`dempath_recon.stereo_track.StereoMarkerTracker`."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('dempath_detector', **kwargs)
        self.declare_parameters('', [(name, default, ParameterDescriptor(description=text))
                                     for name, default, text in PARAMETERS])
        p = {name: self.get_parameter(name).value for name, _, _ in PARAMETERS}
        self.camera = str(p['camera'])
        self.core = StereoMarkerTracker(_load_cameras(str(p['calibration_file'])))
        if self.camera not in self.core.cameras:
            msg = f'camera: {self.camera!r} not in the calibration ({sorted(self.core.cameras)})'
            raise ReconstructionError(msg)
        self.other = self.core.other(self.camera)
        self.pub = self.create_publisher(
            PixelPoints, topics.camera_topic(topics.PIXEL_POINTS, self.camera), 10)
        self.pub_diag = self.create_publisher(DiagnosticArray, '/diagnostics', 10)
        if p['compressed']:
            self.create_subscription(
                CompressedImage, topics.camera_topic(topics.IMAGE_COMPRESSED, self.camera),
                self.on_compressed, 10)
        else:
            self.create_subscription(Image, topics.camera_topic(topics.IMAGE_RAW, self.camera),
                                     self.on_image, 10)
        self.create_subscription(PixelPoints, topics.camera_topic(topics.PIXEL_POINTS, self.other),
                                 self.on_other, 10)
        self.create_timer(float(p['diagnostics_period_s']), self.publish_diagnostics)

    def on_compressed(self, msg: CompressedImage) -> None:
        """Detect in one JPEG frame and publish its numbered markers."""
        frame = self.core.update(self.camera, _stamp_s(msg), bytes(msg.data))
        self.publish(frame, msg.header)

    def on_image(self, msg: Image) -> None:
        """Detect in one raw frame (bgr8 or rgb8)."""
        rows = np.frombuffer(bytes(msg.data), np.uint8).reshape(msg.height, msg.step)
        img = rows[:, :msg.width * 3].reshape(msg.height, msg.width, 3)
        bgr = img[..., ::-1] if msg.encoding == 'rgb8' else img
        frame = self.core.update_image(self.camera, _stamp_s(msg), np.ascontiguousarray(bgr))
        self.publish(frame, msg.header)

    def on_other(self, msg: PixelPoints) -> None:
        """Remember the other camera's numbered markers (for epipolar numbering)."""
        t = _stamp_s(msg)
        for m, u, v in zip(msg.marker_ids, msg.u, msg.v, strict=True):
            self.core.latest[self.other][int(m)] = (t, np.array([u, v], np.float64))

    def publish(self, frame: PixelFrame, header: Any) -> None:
        """PixelPoints of the numbered markers; log the frame's events."""
        for event in frame.events:
            self.get_logger().info(event)
        keep = frame.markers >= 0
        out = PixelPoints(header=header)
        out.header.frame_id = self.camera
        out.marker_ids = [int(m) for m in frame.markers[keep]]
        out.u = frame.uv[keep, 0].tolist()
        out.v = frame.uv[keep, 1].tolist()
        out.confidence = frame.confidence[keep].astype(np.float32).tolist()
        out.source = [PixelPoints.SOURCE_DETECTED] * int(keep.sum())
        self.pub.publish(out)

    def publish_diagnostics(self) -> None:
        """Counts of this camera as one DiagnosticStatus."""
        counts = self.core.report()[self.camera]
        faults = counts['undecodable'] + counts['dropped'] + counts['out_of_order']
        status = DiagnosticStatus(
            level=DiagnosticStatus.WARN if faults else DiagnosticStatus.OK,
            name=f'dempath_detector: {self.camera}', hardware_id=self.camera,
            message=f"{counts['frames']} frames, {counts['detected']} detected, "
                    f"{counts['lost']} lost, {faults} faulty",
            values=[KeyValue(key=k, value=str(v)) for k, v in counts.items() if k != 'gaps_s'])
        self.pub_diag.publish(DiagnosticArray(header=_now_header(self), status=[status]))


def _stamp_s(msg: Any) -> float:
    return float(msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9)


def _now_header(node: Node) -> Any:
    from std_msgs.msg import Header

    return Header(stamp=node.get_clock().now().to_msg())


def _load_cameras(path: str) -> dict[str, Any]:
    """``{name: CameraModel}`` of a stereo YAML; ReconstructionError naming the file."""
    from dempath_calib.camera import StereoCalibration
    from dempath_calib.errors import CalibrationError

    if not path:
        raise ReconstructionError('calibration_file: required (a dempath_calib stereo YAML)')
    try:
        calib = StereoCalibration.load(path)
    except CalibrationError as err:
        raise ReconstructionError(f'{path!r}: {err}') from err
    return {c.name: c for c in calib.cameras}


def main(args: list[str] | None = None) -> int:
    """Console script ``dempath_detector``."""
    return run_node(DetectorNode, args)
