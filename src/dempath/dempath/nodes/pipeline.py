"""Run the player and recorder without launch: for the ``dempath`` command, the demo and benches.

``run_player`` and ``run_recorder`` start one node in the global context (rclpy's SIGINT and
SIGTERM handlers finish them cleanly). ``replay_and_record`` runs player -> recorder in one
process on a private :class:`~dempath.nodes.harness.RosHarness` and waits until the recorder
has received everything the player sent (or a timeout).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.logging import LoggingSeverity
from rclpy.parameter import Parameter

from dempath.nodes.harness import RosHarness
from dempath.nodes.player import PlayerNode
from dempath.nodes.recorder import RecorderNode
from dempath.playback import PlaybackStats
from dempath.recording import TopicStats
from dempath.rosenv import apply_ros_defaults


def _overrides(params: dict[str, Any]) -> list[Parameter]:
    return [Parameter(k, value=list(v) if isinstance(v, tuple) else v) for k, v in params.items()]


def run_player(params: dict[str, Any]) -> PlaybackStats | None:
    """Play a bag with the player node until it finishes or Ctrl-C; return its statistics."""
    apply_ros_defaults()
    rclpy.init()
    node = PlayerNode(parameter_overrides=_overrides(params))
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    try:
        while rclpy.ok() and not node.finished.is_set():
            executor.spin_once(timeout_sec=0.1)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()
    return node.stats


def run_recorder(params: dict[str, Any]) -> str:
    """Record with the recorder node until Ctrl-C or SIGTERM; return its summary."""
    apply_ros_defaults()
    rclpy.init()
    node = RecorderNode(parameter_overrides=_overrides(params))
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    try:
        if node.recorder is not None:
            executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        summary = node.finish()
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()
    return summary


@dataclass
class ReplayResult:
    """Outcome of :func:`replay_and_record`."""

    played: PlaybackStats | None
    recorded: dict[str, TopicStats]
    summary: str
    complete: bool
    wall_s: float


def replay_and_record(bag: str | Path, output: str | Path, topics: list[str],
                      rate: float = 1.0, timeout_s: float = 120.0, quiet: bool = False,
                      **recorder_params: Any) -> ReplayResult:
    """Play ``topics`` of ``bag`` into a recorder writing ``output``, in one process.

    Args:
        bag: Input bag.
        output: Bag directory to create.
        topics: Topics to play and record (both ends get this explicit list).
        rate: Playback speed factor (0: as fast as possible).
        timeout_s: Give up waiting for the end after this long [s].
        quiet: Log only warnings and errors of the two nodes.
        recorder_params: Further recorder parameters (e.g. ``compression``).
    """
    with RosHarness() as harness:
        recorder = harness.start(RecorderNode, output=str(output), topics=list(topics) or [''],
                                 **recorder_params)
        if recorder.recorder is None:
            return ReplayResult(None, {}, '', False, 0.0)
        stats = recorder.recorder.stats
        start = time.monotonic()
        player = harness.start(PlayerNode, bag=str(bag), topics=list(topics) or [''],
                               rate=float(rate), wait_for_subscribers=1)
        for node in (recorder, player) if quiet else ():
            node.get_logger().set_level(LoggingSeverity.WARN)

        def received_all() -> bool:
            if not player.finished.is_set() or player.stats is None:
                return False
            return all(stats.get(t) is not None and stats[t].received + stats[t].dropped >= n
                       for t, n in player.stats.published.items())

        complete = harness.spin_until(received_all, timeout_s=timeout_s, step_s=0.01)
        wall = time.monotonic() - start
        summary = recorder.finish()
        return ReplayResult(player.stats, stats, summary, complete, wall)
