"""The body of every dempath node's console script, in the Jazzy form.

``rclpy.init``; build the node (a bad file or parameter ends with one ``error:`` line and exit
status 1); spin until Ctrl-C, SIGTERM or the node says it is done; then shut down in order: the
node's own finishing step, the executor, the node, the context.

A signal never raises into the node's code: a Python handler only notes it (:class:`StopLatch`,
installed before ``rclpy.init`` so rclpy's own handler passes the signal on to it), and the
spin loop looks at the note between callbacks. A KeyboardInterrupt raised wherever the main
thread happens to be can be lost: inside a finaliser (``__del__``) Python prints "Exception
ignored" and drops it, and a ``dempath_comparer`` went on spinning 60 s after a Ctrl-C that came
while it was being built (once in 103 stress runs; the signal mask below does not stop a thread
a library started before it, such as OpenBLAS's pool, from taking the signal). A second Ctrl-C
does raise, for a callback that never returns. SIGINT and SIGTERM are also held (masked) while
the node is built, so the ROS threads started then never take them.
"""

from __future__ import annotations

import signal
import sys
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from types import FrameType
from typing import TypeVar

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node

from dempath.errors import DempathError
from dempath.rosenv import apply_ros_defaults

N = TypeVar('N', bound=Node)
HELD_SIGNALS = {signal.SIGINT, signal.SIGTERM}  # held while the node is built
SPIN_STEP_S = 0.1  # longest wait between two looks at the stop note [s]


class StopLatch:
    """Notes SIGINT and SIGTERM instead of raising; a second one raises KeyboardInterrupt."""

    def __init__(self) -> None:
        self.caught: list[int] = []

    def __call__(self, signum: int, frame: FrameType | None) -> None:
        self.caught.append(signum)
        if len(self.caught) > 1:  # asked twice: stop whatever runs now
            raise KeyboardInterrupt

    @property
    def stopped(self) -> bool:
        """Whether a stop signal has come."""
        return bool(self.caught)

    @contextmanager
    def installed(self) -> Iterator[StopLatch]:
        """Handle the stop signals here while inside (main thread only; elsewhere a no-op)."""
        if threading.current_thread() is not threading.main_thread():
            yield self
            return
        previous = {sig: signal.signal(sig, self) for sig in HELD_SIGNALS}
        try:
            yield self
        finally:
            for sig, handler in previous.items():
                signal.signal(sig, handler)


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
    with StopLatch().installed() as stop:
        return _run(make_node, stop, args, until, on_exit)


def _run(make_node: Callable[[], N], stop: StopLatch, args: list[str] | None,
         until: Callable[[N], bool] | None, on_exit: Callable[[N], None] | None) -> int:
    """:func:`run_node` with the stop latch installed."""
    signal.pthread_sigmask(signal.SIG_BLOCK, HELD_SIGNALS)
    rclpy.init(args=args)
    try:
        node = make_node()
    except (DempathError, ValueError) as err:
        signal.pthread_sigmask(signal.SIG_UNBLOCK, HELD_SIGNALS)
        print(f'error: {err}', file=sys.stderr)
        rclpy.try_shutdown()
        return 1
    except (KeyboardInterrupt, RuntimeError):
        # a second signal raised during the build, or rclpy's RCLError: its signal handler shut
        # the context down while the node was built: a clean stop, unless the context is still
        # valid and no signal came (then it is a real fault)
        signal.pthread_sigmask(signal.SIG_UNBLOCK, HELD_SIGNALS)
        if rclpy.ok() and not stop.stopped:
            raise
        rclpy.try_shutdown()
        return 0
    executor: SingleThreadedExecutor | None = None
    try:
        signal.pthread_sigmask(signal.SIG_UNBLOCK, HELD_SIGNALS)
        if not stop.stopped and rclpy.ok():
            executor = SingleThreadedExecutor()
            executor.add_node(node)
        while executor is not None and not stop.stopped and rclpy.ok() and not (
                until is not None and until(node)):
            executor.spin_once(timeout_sec=SPIN_STEP_S)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except RuntimeError:  # rclpy's RCLError: the signal's shutdown raced the executor
        if rclpy.ok():  # the context is still valid: a real fault
            raise
    finally:
        if on_exit is not None:
            on_exit(node)
        if executor is not None:
            executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()
    return 0
