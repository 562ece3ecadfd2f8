"""A bounded work queue with a worker thread that counts every item it had to drop.

Live nodes take a frame off their subscription at once (the callback only enqueues, so the
middleware's own queue never overflows unseen) and do the slow work on a worker thread. When the
work falls behind for longer than the queue holds, the oldest waiting item is dropped and counted
(house style 2: latency stays bounded, and no frame is dropped silently); the counts are
published by the node.
"""

from __future__ import annotations

import logging
import threading
from collections import deque
from collections.abc import Callable
from typing import Generic, TypeVar

LOG = logging.getLogger(__name__)
T = TypeVar('T')


class WorkQueue(Generic[T]):
    """Items in, handled in order on one worker thread; overflow drops the oldest and counts it.

    Args:
        handle: Called with each item on the worker thread.
        maxsize: Items that may wait; more means the work is behind and the oldest is dropped.
        name: Thread name (for logs).
    """

    def __init__(self, handle: Callable[[T], None], maxsize: int, name: str = 'worker') -> None:
        if maxsize < 1:
            msg = f'maxsize: must be >= 1, got {maxsize!r}'
            raise ValueError(msg)
        self.handle = handle
        self.maxsize = maxsize
        self.items: deque[T] = deque()
        self.dropped = 0  # items dropped because the queue was full
        self.done = 0  # items handled
        self.most_waiting = 0  # largest number of items waiting at once
        self._cond = threading.Condition()
        self._stop = False
        self._busy = False
        self.thread = threading.Thread(target=self._run, name=name, daemon=True)
        self.thread.start()

    def put(self, item: T) -> None:
        """Enqueue ``item``; drop (and count) the oldest waiting one if full."""
        with self._cond:
            if len(self.items) >= self.maxsize:
                self.items.popleft()
                self.dropped += 1
            self.items.append(item)
            self.most_waiting = max(self.most_waiting, len(self.items))
            self._cond.notify()

    @property
    def waiting(self) -> int:
        """Items waiting now (plus the one being handled)."""
        with self._cond:
            return len(self.items) + int(self._busy)

    def _run(self) -> None:
        while True:
            with self._cond:
                while not self.items and not self._stop:
                    self._cond.wait()
                if self._stop:
                    return
                item = self.items.popleft()
                self._busy = True
            try:
                self.handle(item)
            finally:
                with self._cond:
                    self._busy = False
                    self.done += 1

    def stop(self, timeout_s: float = 5.0) -> None:
        """Stop the worker after the item in hand; waiting items are counted as dropped."""
        with self._cond:
            self._stop = True
            self.dropped += len(self.items)
            self.items.clear()
            self._cond.notify()
        self.thread.join(timeout_s)
