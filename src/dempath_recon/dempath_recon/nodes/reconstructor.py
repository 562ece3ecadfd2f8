"""Reconstruction node: pixel points of both cameras -> 3D marker points with uncertainty.

Subscribes ``/cam_side/pixel_points`` and ``/cam_front/pixel_points`` (dempath_msgs/PixelPoints),
pairs them by stamp within ``slop`` and by marker id, and publishes dempath_msgs/MarkerPoints3D
on ``/markers/points3d`` and a visualization_msgs/MarkerArray on ``/markers/visualization``.
The callbacks only enqueue; a worker thread reconstructs, so live cameras never overflow the
middleware's queue unseen. Frames in, instants out and every drop (a bad frame, the worker
behind by more than ``work_queue`` frames, a frame with no partner) are counted and published
once a second on ``/diagnostics``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.node import Node
from visualization_msgs.msg import MarkerArray

from dempath import topics
from dempath.nodes.diagnostics import counts_message
from dempath.nodes.spin import run_node
from dempath.workqueue import WorkQueue
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
    ('work_queue', 100, 'frames waiting for reconstruction before the oldest is dropped'),
    ('subscription_depth', 50, 'frames the middleware keeps per camera topic'),
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
        self.work: WorkQueue[tuple[PixelPoints, int]] = WorkQueue(
            lambda item: self.on_pixels(*item), int(values.pop('work_queue')), 'reconstructor')
        depth = int(values.pop('subscription_depth'))
        self.config = StreamConfig.from_params(values)
        self.stream = MarkerStream.from_config(self.config)
        self.logged_reasons: set[str] = set()
        self.pub_points = self.create_publisher(MarkerPoints3D, topics.MARKER_POINTS, 10)
        self.pub_viz = self.create_publisher(MarkerArray, topics.MARKER_VIZ, 10)
        self.pub_diag = self.create_publisher(DiagnosticArray, topics.DIAGNOSTICS, 10)
        self.counts = {'frames_side': 0, 'frames_front': 0, 'instants': 0, 'dropped': 0}
        self.create_timer(1.0, self.publish_counts)
        for camera, index in zip(topics.CAMERAS, (SIDE, FRONT), strict=True):
            self.create_subscription(PixelPoints, topics.camera_topic(topics.PIXEL_POINTS, camera),
                                     self.callback_for(index), depth)
        self.get_logger().info(f'reconstructing with {self.config.method!r}, '
                               f'slop {self.config.slop_s} s')

    @property
    def reconstructor(self) -> Any:
        """The fitted method the node uses: ``predict(pixels (n, 4) px) -> (n, 3) m``."""
        return self.stream.reconstructor

    def callback_for(self, camera: int) -> Callable[[PixelPoints], None]:
        """The subscription callback of camera SIDE (0) or FRONT (1): enqueue for the worker."""
        return lambda msg: self.enqueue(msg, camera)

    def enqueue(self, msg: PixelPoints, camera: int) -> None:
        """Count the frame's arrival and hand it to the worker."""
        self.counts['frames_side' if camera == SIDE else 'frames_front'] += 1
        self.work.put((msg, camera))

    def on_pixels(self, msg: PixelPoints, camera: int) -> None:
        """Convert, pair, reconstruct, publish (worker thread); a bad frame is logged, counted."""
        try:
            outputs = self.stream.update(pixel_points_to_frame(msg, camera))
        except ReconstructionError as err:
            self.counts['dropped'] += 1
            self.get_logger().error(f'frame dropped: {err}')
            return
        self.counts['instants'] += len(outputs)
        for frame in outputs:
            self.log_rejections(frame)
            self.pub_points.publish(frame_to_marker_points(frame, self.config.method))
            self.pub_viz.publish(frame_to_marker_array(frame))

    def publish_counts(self) -> None:
        """Frames in per camera, instants out, frames dropped (bad or never paired), waiting."""
        counts = {**self.counts, 'dropped_behind': self.work.dropped,
                  'unpaired': self.stream.sync.unpaired,
                  'waiting': self.work.waiting, 'most_waiting': self.work.most_waiting,
                  'waiting_partner': sum(len(q) for q in self.stream.sync.queues),
                  'rejected_points': sum(self.stream.rejected.values())}
        self.pub_diag.publish(counts_message(self, 'reconstruction', counts,
                                             ('dropped', 'dropped_behind', 'unpaired')))

    def destroy_node(self) -> None:
        """Stop the worker, then the node."""
        self.work.stop()
        super().destroy_node()

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
