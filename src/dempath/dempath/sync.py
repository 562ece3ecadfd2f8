"""Stamp synchronisation of two message streams: one streaming core under one batch form.

Two cameras (or any two sensors) deliver frames with their own stamps. :class:`StampSync` takes
one frame at a time (``update(stream, stamp_s, item)``) and pairs it with the waiting frame of
the other stream whose stamp is nearest, if that is within ``slop_s``; it is what a node runs.
:func:`sync_stamps` is the batch form for offline tools: it feeds two whole stamp sequences
through :class:`StampSync` in time order and returns the index pairs, so live and recorded
pairing agree by construction (``test/test_sync.py`` checks it). The live nodes pair at once
(no latency); offline tools wait for each frame's nearest neighbour (mutual nearest), which
stays exact on irregular clocks; both are modes of the one streaming class.

Every frame leaves the synchroniser exactly once, either in a pair or alone (:class:`Synced`
with ``None`` for the other stream): frames that find no partner are reported, never dropped
silently. ``message_filters`` (ApproximateTime) is not on PyPI, hence this plain module.

Live rule (frames in stamp order per stream): a new frame pairs with the nearest waiting frame
of the other stream within ``slop_s``; waiting frames of the other stream older than that
partner can no longer pair and leave alone; a frame that does not pair waits, and the other
stream's frames older than its stamp minus ``slop_s`` leave alone. With both streams at one
frame rate and ``slop_s`` under half the period the match is the only possible one, the same
as mutual nearest neighbours.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Generic, TypeVar

import numpy as np
from numpy.typing import NDArray

T = TypeVar('T')
STREAMS = (0, 1)


@dataclass(frozen=True)
class Synced(Generic[T]):
    """One output of the synchroniser: a pair, or a frame that found no partner.

    Attributes:
        stamps: stamp of stream 0's and stream 1's frame [s] (None where absent).
        items: the two frames' payloads (None where absent).
    """

    stamps: tuple[float | None, float | None]
    items: tuple[T | None, T | None]

    def pair(self) -> tuple[T, T] | None:
        """The two payloads when both streams' frames are present, else None."""
        a, b = self.items
        return None if a is None or b is None else (a, b)


@dataclass
class _Frame(Generic[T]):
    """A frame waiting in the mutual-nearest mode (``lo``: the other stream's frame before it)."""

    stream: int
    stamp: float
    item: T
    lo: _Frame[T] | None
    nearest: _Frame[T] | None = None
    decided: bool = False


class StampSync(Generic[T]):
    """Streaming nearest-stamp pairing of two streams within ``slop_s``.

    Two ways to decide, one class (the batch form and the tests run both):

    - ``wait_for_nearest=False`` (live nodes): a frame pairs at once with the nearest waiting
      frame of the other stream within ``slop_s``; no latency. With both streams at one frame
      rate and ``slop_s`` under half the period this is the only possible match.
    - ``wait_for_nearest=True`` (offline tools, irregular clocks): two frames pair when each is
      the other's nearest frame (mutual nearest neighbours) and they are within ``slop_s``; a
      frame waits for the other stream's next frame to know its nearest, so a pair leaves one
      frame later (and the last ones at :meth:`flush`). Ties go to the earlier frame.

    Frames must arrive in stamp order, across the two streams too (stream 0 first on equal
    stamps) in the mutual mode; per stream in the live mode.

    Args:
        slop_s: largest stamp difference of a pair [s].
        queue_size: live mode: frames kept per stream while waiting for a partner (None: no
            limit). The mutual mode keeps at most one frame per stream waiting.
        wait_for_nearest: decide by mutual nearest neighbours (see above).
    """

    def __init__(self, slop_s: float, queue_size: int | None = 16,
                 wait_for_nearest: bool = False) -> None:
        if not slop_s >= 0.0:
            msg = f'slop_s: must be >= 0, got {slop_s!r}'
            raise ValueError(msg)
        if queue_size is not None and queue_size < 1:
            msg = f'queue_size: must be >= 1, got {queue_size!r}'
            raise ValueError(msg)
        self.slop_s = slop_s
        self.queue_size = queue_size
        self.wait_for_nearest = wait_for_nearest
        self.queues: tuple[deque[tuple[float, T]], deque[tuple[float, T]]] = (deque(), deque())
        self.unpaired = 0  # frames that left alone so far
        self._last: list[list[_Frame[T]]] = [[], []]  # mutual mode: latest frames per stream
        self._open: list[_Frame[T]] = []  # mutual mode: frames that have not left yet

    def update(self, stream: int, stamp_s: float, item: T) -> list[Synced[T]]:
        """Add one frame of ``stream`` (0 or 1); return what leaves the synchroniser now."""
        if stream not in STREAMS:
            msg = f'stream: must be 0 or 1, got {stream!r}'
            raise ValueError(msg)
        if self.wait_for_nearest:
            return self._update_mutual(stream, float(stamp_s), item)
        return self._update_live(stream, float(stamp_s), item)

    def flush(self) -> list[Synced[T]]:
        """End of both streams: what waits is decided (or leaves alone), oldest first."""
        out: list[Synced[T]] = []
        if self.wait_for_nearest:
            for frame in self._open:
                if not frame.decided:
                    frame.nearest, frame.decided = frame.lo, True
            out = self._settle()
            self._last = [[], []]
        waiting = [(s, k, item) for k in STREAMS for s, item in self.queues[k]]
        for queue in self.queues:
            queue.clear()
        return out + [self._alone(k, s, item)
                      for s, k, item in sorted(waiting, key=lambda w: w[:2])]

    def _update_live(self, stream: int, stamp_s: float, item: T) -> list[Synced[T]]:
        out: list[Synced[T]] = []
        other = self.queues[1 - stream]
        if other:
            gaps = [abs(s - stamp_s) for s, _ in other]
            best = int(np.argmin(gaps))
            if gaps[best] <= self.slop_s:
                for _ in range(best):
                    out.append(self._alone(1 - stream, *other.popleft()))
                partner = other.popleft()
                mine = (stamp_s, item)
                pair = (mine, partner) if stream == 0 else (partner, mine)
                out.append(Synced((pair[0][0], pair[1][0]), (pair[0][1], pair[1][1])))
                return out
        own = self.queues[stream]
        own.append((stamp_s, item))
        while other and other[0][0] < stamp_s - self.slop_s:
            out.append(self._alone(1 - stream, *other.popleft()))
        if self.queue_size is not None and len(own) > self.queue_size:
            out.append(self._alone(stream, *own.popleft()))
        return out

    def _update_mutual(self, stream: int, stamp_s: float, item: T) -> list[Synced[T]]:
        others = self._last[1 - stream]
        lo = next((f for f in reversed(others) if f.stamp < stamp_s), None)
        frame = _Frame(stream, stamp_s, item, lo)
        for waiting in self._open:  # the first frame of this stream at or after theirs
            if waiting.stream != stream and not waiting.decided:
                self._decide(waiting, frame)
        hi = next((f for f in others if f.stamp >= stamp_s), None)  # equal stamps, stream 0
        if hi is not None:
            self._decide(frame, hi)
        self._open.append(frame)
        self._last[stream] = [*self._last[stream][-1:], frame]
        return self._settle()

    @staticmethod
    def _decide(frame: _Frame[T], hi: _Frame[T]) -> None:
        """Nearest of ``frame``: the other stream's frame before it or ``hi`` (ties: before)."""
        lo = frame.lo
        near_lo = lo is not None and frame.stamp - lo.stamp <= hi.stamp - frame.stamp
        frame.nearest, frame.decided = (lo if near_lo else hi), True

    def _settle(self) -> list[Synced[T]]:
        """Frames whose fate is known leave: mutual pairs within the slop, or alone."""
        out: list[Synced[T]] = []
        gone: set[int] = set()
        for frame in self._open:
            if id(frame) in gone or not frame.decided:
                continue
            partner = frame.nearest
            if partner is not None and not partner.decided:
                continue  # the partner does not know its nearest yet
            if partner is not None and partner.nearest is frame \
                    and abs(partner.stamp - frame.stamp) <= self.slop_s:
                a, b = (frame, partner) if frame.stream == 0 else (partner, frame)
                out.append(Synced((a.stamp, b.stamp), (a.item, b.item)))
                gone |= {id(frame), id(partner)}
            else:
                out.append(self._alone(frame.stream, frame.stamp, frame.item))
                gone.add(id(frame))
        self._open = [f for f in self._open if id(f) not in gone]
        return out

    def _alone(self, stream: int, stamp_s: float, item: T) -> Synced[T]:
        self.unpaired += 1
        if stream == 0:
            return Synced((stamp_s, None), (item, None))
        return Synced((None, stamp_s), (None, item))


def sync_stamps(stamps_a: Sequence[float] | NDArray[np.float64],
                stamps_b: Sequence[float] | NDArray[np.float64],
                slop_s: float, wait_for_nearest: bool = True,
                ) -> tuple[list[tuple[int, int]], list[int], list[int]]:
    """Batch form of :class:`StampSync` on two whole stamp sequences.

    The frames of both streams go through :meth:`StampSync.update` merged in stamp order (stream
    0 first on equal stamps), then :meth:`StampSync.flush`; no queue limit.

    Args:
        stamps_a: (n,) stamps of stream 0 [s], ascending.
        stamps_b: (m,) stamps of stream 1 [s], ascending.
        slop_s: largest stamp difference of a pair [s].
        wait_for_nearest: mutual nearest neighbours (offline default) or the live nodes' rule.

    Returns:
        ``(pairs, alone_a, alone_b)``: index pairs ``(i, j)`` in pairing order, and the indices
        of stream 0's and stream 1's frames that found no partner.
    """
    sync: StampSync[int] = StampSync(slop_s, queue_size=None, wait_for_nearest=wait_for_nearest)
    merged = sorted([(float(t), 0, i) for i, t in enumerate(stamps_a)]
                    + [(float(t), 1, j) for j, t in enumerate(stamps_b)])
    events = [e for t, k, i in merged for e in sync.update(k, t, i)] + sync.flush()
    pairs, alone_a, alone_b = [], [], []
    for e in events:
        i, j = e.items
        pair = e.pair()
        if pair is not None:
            pairs.append(pair)
        elif i is not None:
            alone_a.append(i)
        elif j is not None:
            alone_b.append(j)
    return pairs, alone_a, alone_b
