"""The player's core: bag messages handed to a sink at their original pace (or faster).

A reader thread fills a small prefetch queue from the bag, so that reading and decompressing one
message overlaps with publishing the previous one; the calling thread waits until each message
is due, ``(t_bag - t_first) / rate`` after the start, and calls the sink with the raw CDR bytes.
Nothing here imports ROS: the player node's sink publishes.
"""

from __future__ import annotations

import logging
import queue
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any

from dempath.bagio import BagReader, RawMessage
from dempath.errors import BagError

LOG = logging.getLogger(__name__)


@dataclass(frozen=True)
class PlayerConfig:
    """Player settings (ROS parameters of the player node).

    Attributes:
        bag: Bag directory or .mcap/.db3 file.
        rate: Playback speed factor; 0 plays as fast as the subscribers take it.
        start_offset_s: Skip the first seconds of the bag [s].
        loop: Start again at the end (never finishes).
        topics: Topics to play; empty plays all.
        queue_depth: Publisher history depth (reliable QoS).
        wait_for_subscribers: Before starting, wait until each publisher has this many
            subscribers (0: start at once).
        wait_topic_subscribers: Per-topic exceptions to ``wait_for_subscribers``, each
            ``TOPIC=N`` (a topic that several nodes read, e.g. two detectors and a recorder: a
            publisher matches its subscribers one by one, so waiting for the first is not
            waiting for the recorder).
        wait_timeout_s: Longest wait for those subscribers [s]; then play anyway.
        clock_hz: Highest rate of /clock messages [Hz] (one before a message when due).
        prefetch: Messages read ahead of publishing.
        ack_timeout_s: Longest wait, once played, for the subscribers to acknowledge every
            reliable message [s] (the node's FINISHED event names the topics still waiting).
    """

    bag: str
    rate: float = 1.0
    start_offset_s: float = 0.0
    loop: bool = False
    topics: tuple[str, ...] = ()
    queue_depth: int = 50
    wait_for_subscribers: int = 0
    wait_topic_subscribers: tuple[str, ...] = ()
    wait_timeout_s: float = 10.0
    clock_hz: float = 100.0
    prefetch: int = 16
    ack_timeout_s: float = 30.0

    def __post_init__(self) -> None:
        if not self.bag:
            raise ValueError(f'bag: a bag path is required, got {self.bag!r}')
        if min(self.rate, self.start_offset_s, self.wait_timeout_s, self.ack_timeout_s) < 0:
            raise ValueError(f'rate/start_offset_s/wait_timeout_s/ack_timeout_s must be >= 0: '
                             f'{self.rate!r}, {self.start_offset_s!r}, {self.wait_timeout_s!r}, '
                             f'{self.ack_timeout_s!r}')
        if self.queue_depth < 1 or self.prefetch < 1 or self.clock_hz <= 0:
            raise ValueError(f'queue_depth/prefetch >= 1 and clock_hz > 0 required: '
                             f'{self.queue_depth!r}, {self.prefetch!r}, {self.clock_hz!r}')

        self.topic_subscribers()  # a malformed entry fails here, naming it

    def topic_subscribers(self) -> dict[str, int]:
        """The per-topic subscriber counts of ``wait_topic_subscribers``.

        Raises:
            ValueError: an entry is not ``TOPIC=N`` with a topic name and a count >= 0.
        """
        counts: dict[str, int] = {}
        for entry in self.wait_topic_subscribers:
            topic, sep, count = entry.rpartition('=')
            if not sep or not topic.startswith('/') or not count.isdigit():
                raise ValueError(f'wait_topic_subscribers: {entry!r} is not TOPIC=N '
                                 '(an absolute topic name and a count >= 0)')
            counts[topic] = int(count)
        return counts

    def subscribers_needed(self, topic: str) -> int:
        """How many subscribers ``topic``'s publisher waits for before the first message."""
        return self.topic_subscribers().get(topic, self.wait_for_subscribers)

    @classmethod
    def from_params(cls, **params: Any) -> PlayerConfig:
        """Build from ROS parameter values (lists as lists, ignored entries '')."""
        for name in ('topics', 'wait_topic_subscribers'):
            params[name] = tuple(t for t in params.get(name, ()) if t)
        return cls(**params)


@dataclass
class PlaybackStats:
    """What a playback did: messages per topic, loops, lag behind the bag's timing, error.

    ``behind`` counts messages handed over more than ``Playback.BEHIND_S`` after they were
    due and ``max_lag_s`` is the largest such delay [s] (both 0 at rate 0, where nothing is due).
    """

    published: dict[str, int] = field(default_factory=dict)
    loops: int = 0
    error: str | None = None
    behind: int = 0
    max_lag_s: float = 0.0

    @property
    def total(self) -> int:
        """Messages published on all topics."""
        return sum(self.published.values())


_END = object()


def _prefetch(source: Iterator[RawMessage], out: queue.Queue[Any],
              stopped: Callable[[], bool]) -> None:
    """Move messages from ``source`` to ``out`` until exhausted, failed or stopped."""
    try:
        for message in source:
            while not stopped():
                try:
                    out.put(message, timeout=0.1)
                    break
                except queue.Full:
                    continue
            if stopped():
                return
        out.put(_END)
    except BagError as err:
        out.put(err)


class Playback:
    """Plays one opened bag into a sink, honouring rate, offset, topic selection and loop.

    Args:
        bag: The opened bag (see :func:`dempath.bagio.open_bag`).
        config: Player settings.
        topics: Topics to play (the playable subset of ``config.topics`` or of the bag).
    """

    BEHIND_S = 0.02  # a message later than this counts as behind schedule (one 50 FPS frame)

    def __init__(self, bag: BagReader, config: PlayerConfig, topics: list[str]) -> None:
        self.bag = bag
        self.config = config
        self.topics = topics
        self.stop = threading.Event()

    def _one_pass(self, sink: Callable[[RawMessage], None], stats: PlaybackStats) -> bool:
        """Play the bag once; False if stopped or failed."""
        buffer: queue.Queue[Any] = queue.Queue(maxsize=self.config.prefetch)
        source = self.bag.messages(self.topics, self.config.start_offset_s)
        done = threading.Event()
        reader = threading.Thread(
            target=_prefetch, args=(source, buffer, lambda: done.is_set() or self.stop.is_set()),
            name='bag-prefetch', daemon=True)
        reader.start()
        t0_wall, t0_bag = time.monotonic(), None
        try:
            while not self.stop.is_set():
                try:
                    item = buffer.get(timeout=0.2)
                except queue.Empty:
                    if reader.is_alive():
                        continue
                    stats.error = f'{self.bag.path}: the bag reader stopped unexpectedly'
                    return False
                if item is _END:
                    return True
                if isinstance(item, BagError):
                    stats.error = str(item)
                    return False
                t0_bag = item.log_time_ns if t0_bag is None else t0_bag
                if self.config.rate > 0:
                    due = t0_wall + (item.log_time_ns - t0_bag) * 1e-9 / self.config.rate
                    lag = time.monotonic() - due
                    self.stop.wait(max(0.0, -lag))
                    stats.max_lag_s = max(stats.max_lag_s, lag)
                    stats.behind += lag > self.BEHIND_S
                if self.stop.is_set():
                    break
                sink(item)
                stats.published[item.topic] = stats.published.get(item.topic, 0) + 1
            return False
        finally:
            done.set()
            reader.join()

    def run(self, sink: Callable[[RawMessage], None]) -> PlaybackStats:
        """Play until the end (or forever with ``loop``) unless :attr:`stop` is set."""
        stats = PlaybackStats({t: 0 for t in self.topics})
        while self._one_pass(sink, stats):
            stats.loops += 1
            if not self.config.loop or self.stop.is_set():
                break
            LOG.info('%s: looping (pass %d done)', self.bag.path, stats.loops)
        if stats.error:
            LOG.error('%s', stats.error)
        if stats.behind:
            LOG.warning('%s: %d messages published more than %.0f ms late (at most %.3f s)',
                        self.bag.path, stats.behind, self.BEHIND_S * 1e3, stats.max_lag_s)
        return stats
