"""Pass node: announces measured passes of a live rig from the tool's motion or a RunEvent.

Subscribes the tool pose (geometry_msgs/PoseStamped, ``/tool/pose``, sensor-data QoS) or the
upstream events (dempath_msgs/RunEvent, ``/tool/events``), and each camera's pixel points to see
that frames keep coming. Publishes ``/markers/pass_events`` (RunEvent, transient local): STARTED
and FINISHED per pass (run id ``pass_<n>``), or ABORTED with the camera named when one stops
sending frames mid-pass: the points measured so far stay recorded, the pass is marked incomplete.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from geometry_msgs.msg import PoseStamped
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.node import Node
from rclpy.qos import qos_profile_sensor_data

from dempath import topics
from dempath.nodes.msgtypes import reliable_qos
from dempath.nodes.spin import run_node
from dempath_msgs.msg import PixelPoints, RunEvent
from dempath_recon.livepass import CameraWatch, PassChange, PassConfig, PassGate
from dempath_recon.nodes.convert import stamp_to_s

PARAMETERS: tuple[tuple[str, Any, str], ...] = (
    ('trigger', 'tool_motion', 'what starts and ends a pass: tool_motion or run_event'),
    ('start_speed', 0.3, 'tool speed that starts a pass once held [m/s]'),
    ('stop_speed', 0.1, 'tool speed that ends a pass once held [m/s]'),
    ('hold_s', 0.2, 'how long the speed must hold [s]'),
    ('cameras', 'cam_side,cam_front', 'cameras whose pixel points must keep coming'),
    ('camera_timeout_s', 0.5, 'longest gap between frames of a camera mid-pass [s]'),
)


class PassNode(Node):
    """Thin adapter around :class:`dempath_recon.livepass.PassGate` and ``CameraWatch``."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('dempath_pass', **kwargs)
        self.declare_parameters('', [(name, default, ParameterDescriptor(description=text))
                                     for name, default, text in PARAMETERS])
        value = {name: self.get_parameter(name).value for name, _, _ in PARAMETERS}
        self.gate = PassGate(PassConfig(value['trigger'], value['start_speed'],
                                        value['stop_speed'], value['hold_s']))
        cameras = tuple(c.strip() for c in str(value['cameras']).split(',') if c.strip())
        self.watch = CameraWatch(cameras, float(value['camera_timeout_s']))
        self.started_at = 0.0  # monotonic time of the current pass's start
        self.events = self.create_publisher(RunEvent, topics.PASS_EVENTS,
                                            reliable_qos(10, latched=True))
        self.create_subscription(PoseStamped, topics.TOOL_POSE, self.on_pose,
                                 qos_profile_sensor_data)
        self.create_subscription(RunEvent, topics.TOOL_EVENTS, self.on_event, 10)
        for camera in cameras:
            self.create_subscription(
                PixelPoints, topics.camera_topic(topics.PIXEL_POINTS, camera),
                self.seen_by(camera), qos_profile_sensor_data)
        self.create_timer(0.05, self.check_cameras)

    def seen_by(self, camera: str) -> Callable[[PixelPoints], None]:
        """The subscription callback noting that ``camera`` sent a frame."""
        return lambda _msg: self.watch.seen(camera, time.monotonic())

    def on_pose(self, msg: PoseStamped) -> None:
        """Tool position along Z (travel) -> maybe a pass change."""
        self.announce(self.gate.on_tool(stamp_to_s(msg.header.stamp), msg.pose.position.z))

    def on_event(self, msg: RunEvent) -> None:
        """Upstream STARTED / FINISHED / ABORTED -> maybe a pass change."""
        self.announce(self.gate.on_event(msg.event == RunEvent.STARTED,
                                         stamp_to_s(msg.header.stamp), msg.detail))

    def check_cameras(self) -> None:
        """Abort the pass when a camera has stopped sending frames."""
        if not self.gate.active:
            return
        stopped = self.watch.stopped(time.monotonic(), self.started_at)
        if stopped:
            detail = (f'{", ".join(stopped)}: no frame for more than {self.watch.timeout_s} s '
                      f'mid-pass; pass_{self.gate.count} ends incomplete')
            self.get_logger().error(detail)
            self.gate.abort()
            self.publish(RunEvent.ABORTED, self.gate.count, detail)

    def announce(self, change: PassChange | None) -> None:
        """Publish a pass change."""
        if change is None:
            return
        if change.started:
            self.started_at = time.monotonic()
        self.get_logger().info(f'pass_{change.pass_id} {"started" if change.started else "ended"}'
                               f': {change.detail}')
        self.publish(RunEvent.STARTED if change.started else RunEvent.FINISHED, change.pass_id,
                     change.detail)

    def publish(self, event: int, pass_id: int, detail: str) -> None:
        """One RunEvent on the pass topic."""
        msg = RunEvent(run_id=f'pass_{pass_id}', event=event, detail=detail)
        msg.header.stamp = self.get_clock().now().to_msg()
        self.events.publish(msg)


def main(args: list[str] | None = None) -> int:
    """Console script ``dempath_pass``."""
    return run_node(PassNode, args)
