"""Recorder node: raw subscriptions written into a rosbag2 MCAP bag by :mod:`dempath.recording`.

It records the ``topics`` parameter, or every topic under the dempath namespaces (looked for
every ``discovery_period_s``). Subscriptions match the publishers' QoS (transient local topics
keep their latched message). Every message is counted: received, written, dropped (sequence
gaps, messages the middleware reports lost, over the writer's budget) and late; the counts are
logged every ``report_period_s`` and as a summary when the node is destroyed, which finalises
the bag (also on SIGINT/SIGTERM through ``main``). An unwritable output logs one error line
and leaves the node idle, without disturbing other nodes in the process. Frames: the static
transforms of ``frames_file`` on ``/tf_static`` and the tool's pose on ``/tf``
(:mod:`dempath.recording`, docs/ros.md).
"""

from __future__ import annotations

import sys
from functools import partial
from typing import Any

from rcl_interfaces.msg import ParameterDescriptor
from rclpy.event_handler import QoSMessageLostInfo, SubscriptionEventCallbacks
from rclpy.node import Node

from dempath.errors import DempathError
from dempath.nodes.msgtypes import import_message_class, offered_qos_yaml, subscription_qos
from dempath.nodes.spin import run_node
from dempath.recording import BagRecorder, RecorderConfig
from dempath.topics import SIM_TOOL_POSE

PARAMETERS = [
    ('output', '', 'bag directory to create'),
    ('topics', [''], 'topics to record; empty = every dempath topic'),
    ('discovery_period_s', 0.5, 'how often new topics are looked for [s]'),
    ('flush_period_s', 1.0, 'longest time before a written message is on disk [s]'),
    ('chunk_size_bytes', 4 << 20, 'MCAP chunk size [bytes]'),
    ('compression', 'none', 'chunk compression: none or zstd'),
    ('max_queue_bytes', 1 << 30, 'budget of messages waiting for the writer [bytes]'),
    ('late_threshold_s', 0.5, 'received this long after sending counts as late [s]'),
    ('report_period_s', 10.0, 'how often the counts are logged [s]'),
    ('frames_file', '', 'static transforms (YAML, dempath.frames) written to /tf_static; '
                        "'': none"),
    ('tool_pose_topic', SIM_TOOL_POSE, "PoseStamped topic also written as /tf to 'tool'; "
                                       "'': none"),
]
QUEUE_DEPTH = 100  # subscription history: about 2 s of two 50 FPS cameras


class RecorderNode(Node):
    """Subscribes raw to the wanted topics and hands each message to a BagRecorder."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('dempath_recorder', **kwargs)
        self.declare_parameters('', [(n, d, ParameterDescriptor(description=t))
                                     for n, d, t in PARAMETERS])
        self.recorder: BagRecorder | None = None
        self._topic_subs: dict[str, Any] = {}
        self._skipped: set[str] = set()
        self._single_publisher: dict[str, bool] = {}
        try:
            self.config = RecorderConfig.from_params(
                **{n: self.get_parameter(n).value for n, _, _ in PARAMETERS})
            recorder = BagRecorder(self.config)
            recorder.open()
        except (DempathError, ValueError) as err:
            self.get_logger().error(f'not recording: {err}')
            return
        self.recorder = recorder
        self.get_logger().info(f'recording to {self.config.output}')
        self._discover()
        self.create_timer(self.config.discovery_period_s, self._discover)
        self.create_timer(self.config.report_period_s, self._report)

    def subscribed_to(self, topic: str) -> bool:
        """Whether this recorder has subscribed to ``topic`` (found it and wants it)."""
        return topic in self._topic_subs

    def _discover(self) -> None:
        for topic, types in self.get_topic_names_and_types():
            if topic in self._skipped or not self.config.wants(topic):
                continue
            self._single_publisher[topic] = self.count_publishers(topic) == 1
            if topic not in self._topic_subs:
                self._subscribe(topic, types[0])

    def _subscribe(self, topic: str, msgtype: str) -> None:
        assert self.recorder is not None
        try:
            cls = import_message_class(msgtype)
        except DempathError as err:
            self.get_logger().error(f'topic {topic} not recorded: {err}')
            self._skipped.add(topic)
            return
        self.recorder.add_topic(topic, msgtype, offered_qos_yaml(self, topic))
        events = SubscriptionEventCallbacks(message_lost=partial(self._on_lost, topic))
        self._topic_subs[topic] = self.create_subscription(
            cls, topic, partial(self._on_message, topic),
            subscription_qos(self, topic, QUEUE_DEPTH), raw=True, event_callbacks=events)
        self.get_logger().info(f'recording {topic} ({msgtype})')

    def _on_message(self, topic: str, data: bytes, info: dict[str, Any]) -> None:
        if self.recorder is None:
            return
        sent, received = info.get('source_timestamp') or 0, info.get('received_timestamp') or 0
        sequence = info.get('publication_sequence_number') or -1
        self.recorder.submit(topic, data, self.get_clock().now().nanoseconds, sent,
                             sequence if self._single_publisher.get(topic) else -1,
                             latency_ns=received - sent if sent and received else 0)

    def _on_lost(self, topic: str, status: QoSMessageLostInfo) -> None:
        if self.recorder is None:
            return
        self.recorder.count_lost(topic, status.total_count_change)
        self.get_logger().warning(f'{topic}: {status.total_count_change} messages lost')

    def _report(self) -> None:
        if self.recorder is not None:
            self.get_logger().info(self.recorder.summary().splitlines()[-1])

    @property
    def recording(self) -> bool:
        """True while the bag is open (False when it could not be created, or after finish)."""
        return self.recorder is not None

    def received_counts(self) -> dict[str, int]:
        """Messages received so far per topic ({} when not recording)."""
        if self.recorder is None:
            return {}
        return {topic: int(st.received) for topic, st in self.recorder.stats.items()}

    def finish(self) -> str:
        """Finalise the bag (idempotent) and return the per-topic summary ('' if idle)."""
        if self.recorder is None:
            return ''
        recorder, self.recorder = self.recorder, None
        for sub in self._topic_subs.values():
            self.destroy_subscription(sub)
        try:
            recorder.close()
        except DempathError as err:
            self.get_logger().error(str(err))
        summary = recorder.summary()
        if self.context.ok():  # after SIGINT the context is gone; main prints the summary
            self.get_logger().info(f'{self.config.output} closed:\n{summary}')
        return summary

    def destroy_node(self) -> None:
        """Finalise the bag, then destroy the node."""
        self.finish()
        super().destroy_node()


def main(args: list[str] | None = None) -> int:
    """Console script ``dempath_recorder``: record until Ctrl-C or SIGTERM."""
    return run_node(RecorderNode, args, on_exit=lambda node: print(node.finish(), file=sys.stderr))
