"""Frames of two cameras in the order of their stamps, whatever order they arrive in.

The two-camera tracker's result depends on the order it sees the cameras' frames in (a camera's
frame is numbered against the other camera's latest points). Arrival order differs from run to
run in a node graph (two topics, two subscriptions, a loaded machine), so the tracker is fed by
stamp instead: :class:`StampMerge` keeps each camera's frames in their arrival order (one
publisher per topic keeps its own order) and gives out the earliest-stamped head as soon as
every camera has a frame waiting, i.e. when no frame stamped earlier can still come. The batch
path (``track_bag``) and the detector node both use it, so both see the same order.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterable
from typing import Generic, TypeVar

T = TypeVar('T')


class StampMerge(Generic[T]):
    """A k-way merge by stamp of per-camera streams.

    Args:
        cameras: the streams' names.
    """

    def __init__(self, cameras: Iterable[str]) -> None:
        self._queues: dict[str, deque[tuple[float, T]]] = {c: deque() for c in cameras}

    def push(self, camera: str, stamp_s: float, item: T) -> list[tuple[str, float, T]]:
        """Add ``camera``'s next item; the items now due, in stamp order (ties: camera order)."""
        self._queues[camera].append((stamp_s, item))
        out = []
        while all(self._queues.values()):
            out.append(self.pop_earliest())
        return out

    def pop_earliest(self) -> tuple[str, float, T]:
        """The earliest-stamped head of the cameras with something waiting (IndexError: none)."""
        waiting = [c for c, q in self._queues.items() if q]
        if not waiting:
            raise IndexError('nothing waiting')
        camera = min(waiting, key=lambda c: self._queues[c][0][0])
        stamp, item = self._queues[camera].popleft()
        return camera, stamp, item

    def peek_earliest(self) -> T | None:
        """The item :meth:`pop_earliest` would give, without removing it (None: none)."""
        waiting = [q for q in self._queues.values() if q]
        return min(waiting, key=lambda q: q[0][0])[0][1] if waiting else None

    def rest(self) -> list[tuple[str, float, T]]:
        """Everything still waiting, in stamp order (the end of a recording)."""
        out = []
        while any(self._queues.values()):
            out.append(self.pop_earliest())
        return out

    def __len__(self) -> int:
        return sum(len(q) for q in self._queues.values())
