"""Launch-free execution of dempath nodes: one private rclpy context, a probe node and an executor.

Tests, benchmarks and the offline pipeline start any set of nodes in one process with it, without
``ros2 launch``. Each harness has its own ``Context`` and ROS domain id, so parallel processes and
consecutive tests never see each other's traffic. Discovery stays on loopback (see ``rosenv``).
"""

from __future__ import annotations

import itertools
import os
import time
from collections.abc import Callable, Iterable
from typing import Any, TypeVar

import rclpy
from rclpy.context import Context
from rclpy.executors import MultiThreadedExecutor, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.publisher import Publisher
from rclpy.qos import QoSProfile

from dempath.rosenv import apply_ros_defaults

N = TypeVar('N', bound=Node)
_domain_counter = itertools.count()

# Fast DDS derives UDP ports from the domain id; ids 1..100 stay below Linux's ephemeral range.
DOMAIN_ID_SPAN = 100


def unique_domain_id() -> int:
    """A ROS domain id for this process and call, so concurrent test processes stay apart."""
    fixed = os.environ.get('DEMPATH_TEST_DOMAIN_ID')
    if fixed:
        return int(fixed)
    return 1 + (os.getpid() * 7 + next(_domain_counter)) % DOMAIN_ID_SPAN


class RosHarness:
    """A private ROS world: context, probe node for publishing and collecting, and an executor.

    Args:
        domain_id: ROS domain of this harness; a fresh one per process and call by default.
        threads: 1 for a SingleThreadedExecutor, more for a MultiThreadedExecutor.
    """

    def __init__(self, domain_id: int | None = None, threads: int = 1) -> None:
        apply_ros_defaults()
        self.domain_id = unique_domain_id() if domain_id is None else domain_id
        self.context = Context()
        rclpy.init(context=self.context, domain_id=self.domain_id,
                   args=['--ros-args', '--disable-external-lib-logs'])
        self.executor: SingleThreadedExecutor | MultiThreadedExecutor
        if threads > 1:
            self.executor = MultiThreadedExecutor(num_threads=threads, context=self.context)
        else:
            self.executor = SingleThreadedExecutor(context=self.context)
        self.nodes: list[Node] = []
        self.probe = self.add(Node('dempath_probe', context=self.context))

    def add(self, node: N) -> N:
        """Put an already built node (made with ``context=harness.context``) on the executor."""
        self.nodes.append(node)
        self.executor.add_node(node)
        return node

    def start(self, node_class: Callable[..., N], **parameters: Any) -> N:
        """Build ``node_class(context=..., parameter_overrides=...)``; put it on the executor."""
        overrides = [Parameter(name, value=value) for name, value in parameters.items()]
        return self.add(node_class(context=self.context, parameter_overrides=overrides))

    def publisher(self, msg_type: Any, topic: str, qos: QoSProfile | int = 10) -> Publisher:
        """A publisher on the probe node."""
        return self.probe.create_publisher(msg_type, topic, qos)

    def collect(self, msg_type: Any, topic: str, qos: QoSProfile | int = 10) -> list[Any]:
        """Subscribe the probe to ``topic``; the returned list fills as messages arrive."""
        received: list[Any] = []
        self.probe.create_subscription(msg_type, topic, received.append, qos)
        return received

    def spin_until(self, condition: Callable[[], bool], timeout_s: float = 10.0,
                   step_s: float = 0.05) -> bool:
        """Spin the executor until ``condition()`` holds or ``timeout_s`` passes; return it."""
        deadline = time.monotonic() + timeout_s
        while not condition():
            if time.monotonic() > deadline:
                return condition()
            self.executor.spin_once(timeout_sec=step_s)
        return True

    def spin_for(self, duration_s: float) -> None:
        """Spin for a fixed wall time (for checking that nothing arrives)."""
        self.spin_until(lambda: False, timeout_s=duration_s)

    def wait_for_subscribers(self, publisher: Publisher, count: int = 1,
                             timeout_s: float = 10.0) -> bool:
        """Spin until ``publisher`` sees ``count`` matched subscriptions."""
        return self.spin_until(lambda: publisher.get_subscription_count() >= count, timeout_s)

    def publish_all(self, publisher: Publisher, messages: Iterable[Any]) -> None:
        """Publish each message, spinning once in between so that callbacks keep up."""
        for msg in messages:
            publisher.publish(msg)
            self.executor.spin_once(timeout_sec=0.0)

    def shutdown(self) -> None:
        """Stop the executor, destroy every node and shut the context down (idempotent)."""
        self.executor.shutdown()
        for node in reversed(self.nodes):
            node.destroy_node()
        self.nodes.clear()
        rclpy.try_shutdown(context=self.context)

    def __enter__(self) -> RosHarness:
        return self

    def __exit__(self, *exc: object) -> None:
        self.shutdown()
