"""The body of every dempath node's console script, in the Jazzy form.

``rclpy.init``; build the node (a bad file or parameter ends with one ``error:`` line and exit
status 1); spin until Ctrl-C, SIGTERM or the node says it is done (a signal that arrives while
the node is still being built is held until spinning starts, or, when a thread that existed
before the mask took it, ends the start-up with status 0: either way a clean stop); then
shut down in order: the node's own finishing step, the executor, the node, the context.
"""

from __future__ import annotations

import signal
import sys
from collections.abc import Callable
from typing import TypeVar

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node

from dempath.errors import DempathError
from dempath.rosenv import apply_ros_defaults

N = TypeVar('N', bound=Node)
HELD_SIGNALS = {signal.SIGINT, signal.SIGTERM}  # held while the node is built


def run_node(make_node: Callable[[], N], args: list[str] | None = None,
             until: Callable[[N], bool] | None = None,
             on_exit: Callable[[N], None] | None = None) -> int:
    """Run one node in its own process until shutdown; return the exit status.

    Args:
        make_node: The node class (or a factory taking no arguments).
        args: Command-line arguments for ``rclpy.init`` (``--ros-args -p name:=value ...``).
        until: Stop spinning once this returns True (e.g. the player has finished the bag).
        on_exit: Called before the executor shuts down (e.g. finalise a recording).
    """
    apply_ros_defaults()
    # Ctrl-C or SIGTERM while the node is being built is held (in every thread, as the ROS
    # threads inherit the mask) and lands once spinning starts, so it ends the node cleanly.
    signal.pthread_sigmask(signal.SIG_BLOCK, HELD_SIGNALS)
    rclpy.init(args=args)
    try:
        node = make_node()
    except (DempathError, ValueError) as err:
        signal.pthread_sigmask(signal.SIG_UNBLOCK, HELD_SIGNALS)
        print(f'error: {err}', file=sys.stderr)
        rclpy.try_shutdown()
        return 1
    except KeyboardInterrupt:
        # Ctrl-C reached a thread started before the mask (a library's pool, e.g. OpenBLAS's,
        # started at import) and Python raised it in the main thread while the node was built:
        # nothing was recorded yet, so it is a clean stop
        signal.pthread_sigmask(signal.SIG_UNBLOCK, HELD_SIGNALS)
        rclpy.try_shutdown()
        return 0
    except RuntimeError:
        # rclpy's RCLError: a signal reached a thread started before the mask (a library's pool)
        # and shut the context down while the node was built: a clean stop, unless the context
        # is still valid (then it is a real fault)
        signal.pthread_sigmask(signal.SIG_UNBLOCK, HELD_SIGNALS)
        if rclpy.ok():
            raise
        rclpy.try_shutdown()
        return 0
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    try:
        signal.pthread_sigmask(signal.SIG_UNBLOCK, HELD_SIGNALS)
        if until is None:
            executor.spin()
        while until is not None and rclpy.ok() and not until(node):
            executor.spin_once(timeout_sec=0.1)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except RuntimeError:  # rclpy's RCLError: the signal's shutdown raced the executor's wait
        if rclpy.ok():  # the context is still valid: a real fault
            raise
    finally:
        if on_exit is not None:
            on_exit(node)
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()
    return 0
