"""Recalibration progress node: publishes each iteration of a running recalibration.

``dempath recalibrate --publish-progress`` starts it beside the loop; the loop hands it each
:class:`~dempath_diagnose.recalibration.progress.Progress` (through a plain callback, the core
imports no ROS) and it publishes ``dempath_msgs/RecalibrationProgress`` on
``/diagnosis/recalibration`` (transient local: a late Foxglove panel or recorder still gets the
last one). The recorder (``dempath record``, every topic under ``/diagnosis``) records it to MCAP.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from rcl_interfaces.msg import ParameterDescriptor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import Header

from dempath_diagnose.recalibration.progress import Callback, Progress
from dempath_msgs.msg import RecalibrationProgress

TOPIC = '/diagnosis/recalibration'
QOS = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE,
                 durability=DurabilityPolicy.TRANSIENT_LOCAL)
PARAMETERS = (
    ('run_id', '', 'name of the recalibration (the output folder)'),
    ('topic', TOPIC, 'RecalibrationProgress topic'),
    ('frame_id', 'world', 'frame of the published header'),
)


def progress_msg(p: Progress, run_id: str, header: Any) -> RecalibrationProgress:
    """The message of one progress record (an infinite error stays inf: a failed run)."""
    return RecalibrationProgress(
        header=header, run_id=run_id, effect=p.effect, iteration=p.iteration,
        error=float(p.error), best_error=float(p.best_error), floor=float(p.floor),
        floor_significant=float(p.floor_significant), parameter_names=list(p.names),
        parameter_values=[float(v) for v in p.values], simulations=p.simulations,
        eta_s=float(p.eta_s) if math.isfinite(p.eta_s) else 0.0, state=int(p.state),
        detail=p.detail)


class RecalProgressNode(Node):
    """Publishes the progress records handed to :meth:`publish`."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('dempath_recal_progress', **kwargs)
        self.declare_parameters('', [(n, d, ParameterDescriptor(description=t))
                                     for n, d, t in PARAMETERS])
        v = {n: self.get_parameter(n).value for n, _, _ in PARAMETERS}
        self.run_id, self.frame_id = str(v['run_id']), str(v['frame_id'])
        self.pub = self.create_publisher(RecalibrationProgress, str(v['topic']), QOS)
        self.published = 0

    def publish(self, p: Progress) -> None:
        """Publish one record (called from the recalibration's thread; publishing is safe)."""
        header = Header(frame_id=self.frame_id, stamp=self.get_clock().now().to_msg())
        self.pub.publish(progress_msg(p, self.run_id, header))
        self.published += 1
        self.get_logger().info(  # type: ignore[no-untyped-call]
            f'{p.effect} iteration {p.iteration}: error {p.error:.1f} (floor {p.floor:.0f})')


@contextmanager
def progress_publisher(run_id: str, domain_id: int | None = None) -> Iterator[Callback]:
    """A RecalProgressNode on its own context for the time of a command; yields its callback.

    The node only publishes, so nothing spins; the context is shut down on exit. ``domain_id``:
    the ROS domain (``ROS_DOMAIN_ID``'s by default).
    """
    import rclpy
    from rclpy.context import Context
    from rclpy.parameter import Parameter

    from dempath.rosenv import apply_ros_defaults

    apply_ros_defaults()
    ctx = Context()
    extra = {} if domain_id is None else {'domain_id': domain_id}
    rclpy.init(context=ctx, args=['--ros-args', '--disable-external-lib-logs'], **extra)
    node = RecalProgressNode(context=ctx, parameter_overrides=[Parameter('run_id',
                                                                         value=run_id)])
    try:
        yield node.publish
    finally:
        node.destroy_node()
        rclpy.try_shutdown(context=ctx)
