"""Clicker node: publishes a click file as dempath_msgs/PixelPoints with SOURCE_CLICKED.

Each frame's clicks of each camera go out as one message on ``/<camera>/pixel_points``, stamped
with that camera's image stamp (from the bag or folder the clicks were made on), where a detector
publishes its points: manual and automatic tracks flow through the same reconstructor.
``/clicker/events`` (dempath_msgs/RunEvent, transient local) says STARTED and FINISHED.
"""

from __future__ import annotations

import time
from typing import Any

from rcl_interfaces.msg import ParameterDescriptor
from rclpy.node import Node
from std_msgs.msg import Header

from dempath import topics
from dempath.nodes.msgtypes import reliable_qos
from dempath.nodes.spin import run_node
from dempath.nodes.subscribers import subscribed
from dempath_msgs.msg import PixelPoints, RunEvent
from dempath_recon.clicker.playback import ClickerConfig, ClickFrame, load_click_frames
from dempath_recon.nodes.convert import s_to_stamp

PARAMETERS: tuple[tuple[str, Any, str], ...] = (
    ('clicks_file', '', 'click CSV frame,camera,marker,x,y or a per-particle CSV [path]'),
    ('frames', '', 'bag or folder the clicks were made on, for image stamps [path]'),
    ('fps', 50.0, 'frame rate where no image stamp is known [1/s]'),
    ('markers', '1-15', 'marker numbers the file may hold'),
    ('image_width', 1920, 'image width when frames is empty [px]'),
    ('image_height', 1080, 'image height when frames is empty [px]'),
    ('rate_hz', 50.0, 'frames published per second of wall time [1/s]'),
    ('wait_for_subscribers', 0, 'subscribers each topic needs before the first frame'),
    ('wait_timeout_s', 10.0, 'longest wait for them [s]'),
)


def to_message(frame: ClickFrame) -> PixelPoints:
    """One camera's clicks of one frame -> dempath_msgs/PixelPoints (SOURCE_CLICKED)."""
    n = len(frame.ids)
    return PixelPoints(header=Header(stamp=s_to_stamp(frame.stamp_s), frame_id=frame.camera),
                       marker_ids=frame.ids.tolist(), u=frame.uv[:, 0].tolist(),
                       v=frame.uv[:, 1].tolist(), confidence=[1.0] * n,
                       source=[PixelPoints.SOURCE_CLICKED] * n)


class ClickerNode(Node):
    """Publishes the frames of a click file, one frame index per timer tick."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('dempath_clicker', **kwargs)
        self.declare_parameters('', [(name, default, ParameterDescriptor(description=text))
                                     for name, default, text in PARAMETERS])
        self.config = ClickerConfig.from_params(
            {name: self.get_parameter(name).value for name, _, _ in PARAMETERS})
        self.frames = load_click_frames(self.config)
        self.pubs = {camera: self.create_publisher(
            PixelPoints, topics.camera_topic(topics.PIXEL_POINTS, camera), 10)
            for camera in dict.fromkeys(f.camera for f in self.frames)}
        self.events = self.create_publisher(RunEvent, topics.CLICKER_EVENTS,
                                            reliable_qos(10, latched=True))
        self.next = 0
        self.published = 0
        self.finished_at: float | None = None  # monotonic time of the FINISHED event
        self.started_s = self.get_clock().now().nanoseconds * 1e-9
        self.timer = self.create_timer(1.0 / self.config.rate_hz, self.tick)

    @property
    def done(self) -> bool:
        """Whether every frame has been published."""
        return self.next >= len(self.frames)

    def finished_for(self, seconds: float) -> bool:
        """Whether everything was published at least ``seconds`` ago (time to deliver it)."""
        return self.finished_at is not None and time.monotonic() - self.finished_at >= seconds

    def ready(self) -> bool:
        """Whether the wanted subscribers are there (or the wait has timed out)."""
        waited = self.get_clock().now().nanoseconds * 1e-9 - self.started_s
        return waited > self.config.wait_timeout_s or subscribed(
            self.pubs.values(), self.config.wait_for_subscribers)

    def tick(self) -> None:
        """Publish the next frame index's messages (all cameras); announce start and end."""
        if self.done or not self.ready():
            return
        if self.next == 0:
            self.event(RunEvent.STARTED, f'{len(self.frames)} camera frames of clicks')
        index = self.frames[self.next].frame
        while not self.done and self.frames[self.next].frame == index:
            frame = self.frames[self.next]
            self.pubs[frame.camera].publish(to_message(frame))
            self.published += len(frame.ids)
            self.next += 1
        if self.done:
            self.event(RunEvent.FINISHED, f'published {self.published} clicked points of '
                       f'{self.config.clicks_file}')
            self.timer.cancel()
            self.finished_at = time.monotonic()

    def event(self, event: int, detail: str) -> None:
        """Announce a RunEvent (run id: the click file)."""
        msg = RunEvent(run_id=self.config.clicks_file, event=event, detail=detail)
        msg.header.stamp = self.get_clock().now().to_msg()
        self.events.publish(msg)
        self.get_logger().info(detail)


def main(args: list[str] | None = None) -> int:
    """Console script ``dempath_clicker``: publish a click file, then exit."""
    return run_node(ClickerNode, args, until=lambda node: node.finished_for(0.5))
