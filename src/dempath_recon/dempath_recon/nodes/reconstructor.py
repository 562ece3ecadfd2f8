"""Reconstruction node: pixel points of both cameras -> 3D marker points with uncertainty.

Subscribes ``/cam_side/pixel_points`` and ``/cam_front/pixel_points`` (dempath_msgs/PixelPoints),
pairs them by stamp within ``slop`` and by marker id, and publishes dempath_msgs/MarkerPoints3D
on ``/markers/points3d`` and a visualization_msgs/MarkerArray on ``/markers/visualization``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from rcl_interfaces.msg import ParameterDescriptor
from rclpy.node import Node
from visualization_msgs.msg import MarkerArray

from dempath import topics
from dempath.nodes.spin import run_node
from dempath_msgs.msg import MarkerPoints3D, PixelPoints
from dempath_recon.errors import ReconstructionError
from dempath_recon.nodes.convert import (
    frame_to_marker_array,
    frame_to_marker_points,
    pixel_points_to_frame,
)
from dempath_recon.pairing import FRONT, SIDE
from dempath_recon.stream import MarkerFrame3D, MarkerStream, StreamConfig

PARAMETERS: tuple[tuple[str, Any, str], ...] = (
    ('method', 'dlt', 'reconstruction method: dlt, dlt_refined, dlt_residual or mlp'),
    ('calibration_file', '', 'stereo calibration YAML (dempath_calib) [path]'),
    ('model_file', '', 'trained model file for mlp / dlt_residual [path]'),
    ('slop', 0.01, 'largest stamp difference of paired camera frames [s]'),
    ('sigma_x_px', 2.36, "1-sigma pixel noise along x, the paper's clicking [px]"),
    ('sigma_y_px', 2.75, "1-sigma pixel noise along y, the paper's clicking [px]"),
    ('image_width', 1920, 'image width when no calibration gives it [px]'),
    ('image_height', 1080, 'image height when no calibration gives it [px]'),
    ('queue_size', 16, 'frames kept per camera while waiting for a partner'),
    ('device', 'cpu', 'torch device of the learned methods (cpu, cuda, auto)'),
)


class ReconstructorNode(Node):
    """Thin adapter around :class:`dempath_recon.stream.MarkerStream`."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('dempath_reconstructor', **kwargs)
        self.declare_parameters('', [(name, default, ParameterDescriptor(description=text))
                                     for name, default, text in PARAMETERS])
        values = {name: self.get_parameter(name).value for name, _, _ in PARAMETERS}
        values['slop_s'] = values.pop('slop')
        self.config = StreamConfig.from_params(values)
        self.stream = MarkerStream.from_config(self.config)
        self.logged_reasons: set[str] = set()
        self.pub_points = self.create_publisher(MarkerPoints3D, topics.MARKER_POINTS, 10)
        self.pub_viz = self.create_publisher(MarkerArray, topics.MARKER_VIZ, 10)
        for camera, index in zip(topics.CAMERAS, (SIDE, FRONT), strict=True):
            self.create_subscription(PixelPoints, topics.camera_topic(topics.PIXEL_POINTS, camera),
                                     self.callback_for(index), 10)
        self.get_logger().info(f'reconstructing with {self.config.method!r}, '
                               f'slop {self.config.slop_s} s')

    @property
    def reconstructor(self) -> Any:
        """The fitted method the node uses: ``predict(pixels (n, 4) px) -> (n, 3) m``."""
        return self.stream.reconstructor

    def callback_for(self, camera: int) -> Callable[[PixelPoints], None]:
        """The subscription callback of camera SIDE (0) or FRONT (1)."""
        return lambda msg: self.on_pixels(msg, camera)

    def on_pixels(self, msg: PixelPoints, camera: int) -> None:
        """Convert, pair, reconstruct, publish; a bad frame is logged and dropped."""
        try:
            outputs = self.stream.update(pixel_points_to_frame(msg, camera))
        except ReconstructionError as err:
            self.get_logger().error(f'frame dropped: {err}')
            return
        for frame in outputs:
            self.log_rejections(frame)
            self.pub_points.publish(frame_to_marker_points(frame, self.config.method))
            self.pub_viz.publish(frame_to_marker_array(frame))

    def log_rejections(self, frame: MarkerFrame3D) -> None:
        """Warn once per cause; the totals stay in ``stream.rejected``."""
        for reason, count in frame.rejected.items():
            if reason not in self.logged_reasons:
                self.logged_reasons.add(reason)
                self.get_logger().warning(
                    f'rejected {count} point(s) at t={frame.stamp_s:.3f} s: {reason} '
                    '(logged once per cause, counted in stream.rejected)')


def main(args: list[str] | None = None) -> int:
    """Console script ``dempath_reconstructor``; a bad file gives one error line and 1."""
    return run_node(ReconstructorNode, args)
