"""Player node: replays a rosbag2 bag (MCAP or sqlite3) with its original timing and stamps.

The raw CDR bytes of each message are published as they are (header stamps unchanged), /clock
follows the bag time, and ``/player/events`` (dempath_msgs/RunEvent, transient local) says
STARTED, then FINISHED or ABORTED, so that pipelines know when the bag is done. FINISHED is
sent (and the console script exits) only once every subscriber has acknowledged every reliable
message, or after ``ack_timeout_s``, when the event names the topics whose messages were not all
acknowledged: on a loaded machine the player used to exit with its last frames still unsent
(7 frames per camera lost in one run of the demo graph). A topic whose
message class cannot be imported is skipped with one error line; the rest plays. A bad bag
logs one error line and an ABORTED event; the node stays up and harms no other node.
"""

from __future__ import annotations

import threading
import time
from typing import Any

from builtin_interfaces.msg import Time
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.duration import Duration
from rclpy.node import Node
from rosgraph_msgs.msg import Clock

from dempath import topics
from dempath.bagio import RawMessage, open_bag
from dempath.errors import DempathError
from dempath.nodes.msgtypes import import_message_class, reliable_qos
from dempath.nodes.spin import run_node
from dempath.nodes.subscribers import wait_for_subscribers
from dempath.playback import Playback, PlaybackStats, PlayerConfig
from dempath_msgs.msg import RunEvent

PARAMETERS = [
    ('bag', '', 'bag directory or .mcap/.db3 file'),
    ('rate', 1.0, 'playback speed factor; 0 = as fast as possible'),
    ('start_offset_s', 0.0, 'skip the first seconds of the bag [s]'),
    ('loop', False, 'start again at the end'),
    ('topics', [''], 'topics to play; empty = all'),
    ('queue_depth', 50, 'publisher history depth (reliable)'),
    ('wait_for_subscribers', 0, 'wait until each topic has this many subscribers'),
    ('wait_topic_subscribers', [''], "per-topic exceptions, each 'TOPIC=N'"),
    ('wait_timeout_s', 10.0, 'longest wait for those subscribers [s]'),
    ('clock_hz', 100.0, 'highest /clock rate [Hz]'),
    ('prefetch', 16, 'messages read ahead'),
    ('ack_timeout_s', 30.0, 'longest wait for subscribers to acknowledge every message [s]'),
]


class PlayerNode(Node):
    """Publishes a bag's messages on their topics from a playback thread."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('dempath_player', **kwargs)
        self.declare_parameters('', [(n, d, ParameterDescriptor(description=t))
                                     for n, d, t in PARAMETERS])
        self.finished = threading.Event()
        self._stats: PlaybackStats | None = None
        self._event_pub = self.create_publisher(
            RunEvent, topics.PLAYER_EVENTS, reliable_qos(10, latched=True))
        self._clock_pub = self.create_publisher(Clock, topics.CLOCK, 10)
        self._last_clock = 0.0
        self._topic_pubs: dict[str, Any] = {}
        self._playback: Playback | None = None
        try:
            self.config = PlayerConfig.from_params(
                **{n: self.get_parameter(n).value for n, _, _ in PARAMETERS})
            self._bag = open_bag(self.config.bag, self.config.topics, strict_types=False)
        except (DempathError, ValueError) as err:
            self._end(RunEvent.ABORTED, str(err), error=True)
            return
        for info in self._bag.select(self.config.topics):
            try:
                cls = import_message_class(info.msgtype)
            except DempathError as err:
                self.get_logger().error(f'{self.config.bag}: topic {info.name} skipped: {err}')
                continue
            self._topic_pubs[info.name] = self.create_publisher(
                cls, info.name, reliable_qos(self.config.queue_depth, info.latched))
        self._playback = Playback(self._bag, self.config, sorted(self._topic_pubs))
        threading.Thread(target=self._run, name='player', daemon=True).start()

    @property
    def stats(self) -> PlaybackStats | None:
        """What the playback published (None until it has ended; ``finished`` is set then)."""
        return self._stats

    def published(self) -> dict[str, int]:
        """Messages published per topic (empty until the playback has ended)."""
        return dict(self._stats.published) if self._stats is not None else {}

    def _end(self, event: int, detail: str, error: bool = False) -> None:
        (self.get_logger().error if error else self.get_logger().info)(detail)
        self._event(event, detail)
        self.finished.set()

    def _event(self, event: int, detail: str) -> None:
        msg = RunEvent(run_id=str(self.get_parameter('bag').value), event=event, detail=detail)
        msg.header.stamp = self.get_clock().now().to_msg()
        self._event_pub.publish(msg)

    def _publish(self, message: RawMessage) -> None:
        now = time.monotonic()
        if now - self._last_clock >= 1.0 / self.config.clock_hz:
            self._last_clock = now
            sec, nsec = divmod(message.log_time_ns, 1_000_000_000)
            self._clock_pub.publish(Clock(clock=Time(sec=sec, nanosec=nsec)))
        self._topic_pubs[message.topic].publish(message.data)

    def _run(self) -> None:
        assert self._playback is not None
        self._wait_for_subscribers()
        self._event(RunEvent.STARTED, f'playing {len(self._topic_pubs)} topics')
        self._stats = stats = self._playback.run(self._publish)
        self._bag.close()
        if stats.error:
            self._end(RunEvent.ABORTED, stats.error, error=True)
        elif self._playback.stop.is_set():
            self._end(RunEvent.ABORTED, f'{self.config.bag}: stopped after '
                      f'{stats.total} messages')
        else:
            unacked = self._wait_for_acks()
            delivered = 'every message acknowledged' if not unacked else (
                f'NOT all acknowledged within {self.config.ack_timeout_s:g} s on '
                + ', '.join(unacked))
            self._end(RunEvent.FINISHED, f'{self.config.bag}: published {stats.total} '
                      f'messages on {len(self._topic_pubs)} topics, {stats.behind} '
                      f'behind schedule (max {stats.max_lag_s:.3f} s); {delivered}',
                      error=bool(unacked))

    def _wait_for_subscribers(self) -> None:
        """Hold the first message until each topic has the subscribers it waits for; after
        ``wait_timeout_s`` play anyway and name the topics short of them."""
        assert self._playback is not None
        deadline = time.monotonic() + self.config.wait_timeout_s
        for topic, pub in self._topic_pubs.items():
            need = self.config.subscribers_needed(topic)
            left = max(0.0, deadline - time.monotonic())
            if not wait_for_subscribers([pub], need, left, self._playback.stop) and \
                    not self._playback.stop.is_set():
                self.get_logger().warning(
                    f'{topic}: playing with {pub.get_subscription_count()} of the {need} '
                    f'subscribers waited for (wait_timeout_s {self.config.wait_timeout_s:g})')

    def _wait_for_acks(self) -> list[str]:
        """Wait (up to ``ack_timeout_s`` in all) until the subscribers have acknowledged every
        reliable message; the topics still waiting then."""
        deadline = time.monotonic() + max(self.config.ack_timeout_s, 0.0)
        late = []
        for name, pub in sorted(self._topic_pubs.items()):
            left = max(deadline - time.monotonic(), 0.0)
            if not pub.wait_for_all_acked(Duration(seconds=left)):
                late.append(name)
        return late

    def destroy_node(self) -> None:
        """Stop the playback thread, then destroy the node."""
        if self._playback is not None:
            self._playback.stop.set()
            self.finished.wait(timeout=5.0)
        super().destroy_node()


def main(args: list[str] | None = None) -> int:
    """Console script ``dempath_player``: play, then exit when finished (or on Ctrl-C)."""
    return run_node(PlayerNode, args, until=lambda node: node.finished.is_set())
