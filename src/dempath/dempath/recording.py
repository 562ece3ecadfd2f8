"""The recorder's core: accounting of every message and a writer thread behind a byte budget.

The node hands each received CDR message to :meth:`BagRecorder.submit` and returns at once; a
worker thread writes the MCAP (:class:`dempath.mcapbag.McapBagWriter`) and closes a chunk at
least every ``flush_period_s``, so that a SIGKILL loses at most that much. Nothing is dropped
silently: per topic the recorder counts messages received, written, dropped (queue over budget,
a write failure, lost in transport as the node reports it) and late (received more than
``late_threshold_s`` after they were sent; they are still written).

Frames (:mod:`dempath.frames`): given a ``frames_file``, the bag starts with those static
transforms on ``/tf_static``; given a ``tool_pose_topic``, every PoseStamped recorded there is
also written as a ``/tf`` transform to the ``tool`` frame, with the pose's stamp. So every bag
the recorder writes places the cameras, the tool and everything stamped in their frames in
Foxglove, without tf2 in the process.
"""

from __future__ import annotations

import logging
import queue
import threading
import time
from dataclasses import dataclass, field
from typing import Any

import yaml
from rosbags.typesys.store import Typestore

from dempath.errors import DempathError, OutputError
from dempath.frames import TF, TF_STATIC, TF_TYPE, load_frames, pose_tf_cdr, tf_message
from dempath.mcapbag import COMPRESSIONS, McapBagWriter
from dempath.topics import is_dempath_topic
from dempath.typestore import make_typestore, message_definition

LOG = logging.getLogger(__name__)
_INFINITE = {'sec': 9223372036, 'nsec': 854775807}  # rmw's "infinite" duration
LATCHED_QOS = yaml.safe_dump([{  # offered QoS of /tf_static in metadata.yaml (as tf2 offers)
    'history': 'keep_last', 'depth': 1, 'reliability': 'reliable',
    'durability': 'transient_local', 'deadline': _INFINITE, 'lifespan': _INFINITE,
    'liveliness': 'automatic', 'liveliness_lease_duration': _INFINITE,
    'avoid_ros_namespace_conventions': False}])


@dataclass(frozen=True)
class RecorderConfig:
    """Recorder settings (ROS parameters of the recorder node).

    Attributes:
        output: Bag directory to create.
        topics: Topics to record; empty means every topic under the dempath namespaces.
        discovery_period_s: How often new topics are looked for [s].
        flush_period_s: Longest time a written message waits before its chunk is closed [s].
        chunk_size_bytes: Size that closes a chunk by itself [bytes].
        compression: Chunk compression: none or zstd.
        max_queue_bytes: Budget of messages waiting for the writer [bytes]; beyond it they are
            dropped and counted.
        late_threshold_s: A message received this long after it was sent counts as late [s].
        report_period_s: How often the node logs the counts [s].
        frames_file: Static transforms (YAML of :func:`dempath.frames.save_frames`) written to
            ``/tf_static`` when the bag opens; '' for none.
        tool_pose_topic: PoseStamped topic also written as ``/tf`` (its frame -> ``tool``);
            '' for none.
    """

    output: str
    topics: tuple[str, ...] = ()
    discovery_period_s: float = 0.5
    flush_period_s: float = 1.0
    chunk_size_bytes: int = 4 << 20
    compression: str = 'none'
    max_queue_bytes: int = 1 << 30
    late_threshold_s: float = 0.5
    report_period_s: float = 10.0
    frames_file: str = ''
    tool_pose_topic: str = ''

    def __post_init__(self) -> None:
        if not self.output:
            raise ValueError(f'output: a bag directory is required, got {self.output!r}')
        for name in ('discovery_period_s', 'flush_period_s', 'late_threshold_s',
                     'report_period_s'):
            if not getattr(self, name) > 0:
                raise ValueError(f'{name}: must be > 0, got {getattr(self, name)!r}')
        if self.chunk_size_bytes < 1024 or self.max_queue_bytes < 1 << 20:
            raise ValueError(f'chunk_size_bytes/max_queue_bytes too small: '
                             f'{self.chunk_size_bytes!r}, {self.max_queue_bytes!r}')
        if self.compression not in COMPRESSIONS:
            raise ValueError(f'compression: one of {sorted(COMPRESSIONS)}, '
                             f'got {self.compression!r}')

    @classmethod
    def from_params(cls, **params: Any) -> RecorderConfig:
        """Build from ROS parameter values (``topics`` as a list, ignored entries '')."""
        params['topics'] = tuple(t for t in params.get('topics', ()) if t)
        return cls(**params)

    def wants(self, topic: str) -> bool:
        """Whether ``topic`` is to be recorded."""
        return topic in self.topics if self.topics else is_dempath_topic(topic)


@dataclass
class TopicStats:
    """Message accounting of one topic."""

    received: int = 0
    written: int = 0
    dropped: int = 0
    late: int = 0
    last_sequence: int = field(default=-1, repr=False)


_STOP = object()


class BagRecorder:
    """Records CDR messages into one MCAP bag from any thread; writes in its own thread.

    Args:
        config: Recorder settings.
        typestore: Store used to find message definitions; a fresh one by default.
    """

    def __init__(self, config: RecorderConfig, typestore: Typestore | None = None) -> None:
        self.config = config
        self.stats: dict[str, TopicStats] = {}
        self.failure: str | None = None
        self._store = typestore
        self._writer = McapBagWriter(config.output, config.chunk_size_bytes, config.compression)
        self._channels: dict[str, int] = {}
        self._queue: queue.SimpleQueue[Any] = queue.SimpleQueue()
        self._queued_bytes = 0
        self._lock = threading.Lock()
        self._thread: threading.Thread | None = None

    def open(self) -> None:
        """Create the bag and start the writer thread.

        Raises:
            OutputError: The output directory cannot be created or written.
        """
        static = []
        if self.config.frames_file:
            try:
                static = load_frames(self.config.frames_file)
            except DempathError as err:
                raise OutputError(str(err)) from err
        self._writer.open()
        self._store = self._store or make_typestore()
        self._thread = threading.Thread(target=self._run, name='bag-writer', daemon=True)
        self._thread.start()
        if static:
            now = time.time_ns()
            self.add_topic(TF_STATIC, TF_TYPE, LATCHED_QOS)
            self.submit(TF_STATIC, bytes(self._store.serialize_cdr(
                tf_message(self._store, static, now), TF_TYPE)), now)

    def add_topic(self, topic: str, msgtype: str, offered_qos: str = '') -> None:
        """Start a topic (its schema is the full definition of ``msgtype`` when known)."""
        assert self._store is not None, 'open() first'
        msgdef = message_definition(self._store, msgtype)
        if not msgdef:
            LOG.warning('%s: no definition of %s found; recording %s without schema',
                        self.config.output, msgtype, topic)
        with self._lock:
            self.stats.setdefault(topic, TopicStats())
            self._queue.put(('topic', topic, msgtype, msgdef, offered_qos))

    def submit(self, topic: str, data: bytes, log_time_ns: int, publish_time_ns: int = 0,
               sequence: int = -1, latency_ns: int = 0) -> bool:
        """Queue one message for writing; False if it had to be dropped (and was counted).

        Args:
            topic: A topic given to :meth:`add_topic`.
            data: CDR bytes.
            log_time_ns: Receive time [ns] (bag time).
            publish_time_ns: Send time [ns] (0: unknown).
            sequence: Publisher's sequence number; gaps count as dropped (-1: unknown).
            latency_ns: Receive minus send time [ns] (0: unknown); above the threshold the
                message counts as late.
        """
        with self._lock:
            st = self.stats[topic]
            st.received += 1
            if sequence >= 0 and st.last_sequence >= 0 and sequence > st.last_sequence + 1:
                st.dropped += sequence - st.last_sequence - 1
            st.last_sequence = sequence if sequence >= 0 else st.last_sequence
            if latency_ns > self.config.late_threshold_s * 1e9:
                st.late += 1
            full = self._queued_bytes + len(data) > self.config.max_queue_bytes
            if self.failure is not None or full:
                st.dropped += 1
                return False
            self._queued_bytes += len(data)
        self._queue.put(('msg', topic, data, log_time_ns, publish_time_ns, sequence))
        if topic == self.config.tool_pose_topic and topic:
            self._submit_tool_tf(data, log_time_ns)
        return True

    def _submit_tool_tf(self, pose_cdr: bytes, log_time_ns: int) -> None:
        """The tool's pose also as ``/tf`` (counted on that topic like any message)."""
        assert self._store is not None
        if TF not in self.stats:
            self.add_topic(TF, TF_TYPE)
        try:
            data = pose_tf_cdr(self._store, pose_cdr)
        except (ValueError, KeyError, IndexError) as err:  # rosbags' CDR errors are ValueErrors
            LOG.warning('%s: a tool pose not written to /tf: %s', self.config.tool_pose_topic,
                        err)
            return
        self.submit(TF, data, log_time_ns)

    def count_lost(self, topic: str, count: int) -> None:
        """Count messages the transport reports lost before they reached the recorder."""
        with self._lock:
            self.stats.setdefault(topic, TopicStats()).dropped += count

    def _handle(self, item: tuple[Any, ...]) -> None:
        if item[0] == 'topic':
            _, topic, msgtype, msgdef, qos = item
            self._channels[topic] = self._writer.add_topic(topic, msgtype, msgdef, qos)
            return
        _, topic, data, log_ns, pub_ns, seq = item
        with self._lock:
            self._queued_bytes -= len(data)
        if self.failure is not None:
            with self._lock:
                self.stats[topic].dropped += 1
            return
        self._writer.write(self._channels[topic], log_ns, data, pub_ns, max(seq, 0))
        with self._lock:
            self.stats[topic].written += 1

    def _run(self) -> None:
        last_flush = time.monotonic()
        while True:
            timeout = max(0.0, last_flush + self.config.flush_period_s - time.monotonic())
            try:
                item = self._queue.get(timeout=timeout)
            except queue.Empty:
                item = None
            if item is _STOP:
                break
            try:
                if item is not None:
                    self._handle(item)
                if time.monotonic() - last_flush >= self.config.flush_period_s:
                    self._writer.flush()
                    last_flush = time.monotonic()
            except OSError as err:
                self.failure = f'{self.config.output}: writing failed: {err}'
                LOG.error('%s; later messages are counted as dropped', self.failure)

    def close(self) -> dict[str, TopicStats]:
        """Write what is queued, finalise the MCAP and metadata.yaml; return the counts.

        Raises:
            OutputError: The bag could not be finalised (what was flushed stays readable).
        """
        if self._thread is not None:
            self._queue.put(_STOP)
            self._thread.join()
            self._thread = None
            try:
                self._writer.close()
            except OSError as err:
                msg = f'{self.config.output}: cannot finalise the bag: {err}'
                raise OutputError(msg) from err
        return self.stats

    def summary(self) -> str:
        """One line per topic, a total, and the requested topics that never appeared."""
        with self._lock:
            rows = sorted(self.stats.items())
        lines = [f'{t}: received {s.received}, written {s.written}, dropped {s.dropped}, '
                 f'late {s.late}' for t, s in rows]
        total = [sum(getattr(s, k) for _, s in rows)
                 for k in ('received', 'written', 'dropped', 'late')]
        lines.append('total: received {}, written {}, dropped {}, late {}'.format(*total))
        absent = [t for t in self.config.topics if t not in self.stats]
        if absent:
            lines.append(f'never seen (nothing recorded): {", ".join(absent)}')
        return '\n'.join(lines)
