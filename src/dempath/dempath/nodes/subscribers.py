"""Holding a publisher's first message until its subscribers are there.

DDS discovery takes a moment: a node that publishes a recording or a simulation at once loses
its first messages to a recorder that has not matched yet. The player, the clicker and the
simulator therefore wait (with a timeout) until each of their data publishers has the wanted
number of subscribers.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Iterable

from rclpy.publisher import Publisher

POLL_S = 0.02  # how often the subscription counts are read [s]


def subscribed(publishers: Iterable[Publisher], need: int) -> bool:
    """Whether every publisher has at least ``need`` subscribers (always true for 0)."""
    return all(p.get_subscription_count() >= need for p in publishers)


def wait_for_subscribers(publishers: Iterable[Publisher], need: int, timeout_s: float,
                         stop: threading.Event | None = None) -> bool:
    """Block until every publisher has ``need`` subscribers, ``timeout_s`` passed or ``stop``
    is set (a Ctrl-C ends the wait: the node is destroyed next).

    Returns:
        Whether the subscribers are there.
    """
    pubs = list(publishers)
    deadline = time.monotonic() + timeout_s
    while not subscribed(pubs, need):
        if time.monotonic() >= deadline or (stop is not None and stop.is_set()):
            return False
        time.sleep(POLL_S)
    return True
