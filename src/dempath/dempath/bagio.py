"""Bag input and output without ROS: a typestore with dempath_msgs, validated reading, writers.

The typestore is rosbags' ROS 2 Jazzy store plus every ``dempath_msgs`` type parsed from its
``.msg`` text (installed under ``sys.prefix/share/dempath_msgs/msg``, or the source tree). Types
defined in a bag itself (its ``ros2msg`` schemas) are registered when the bag is opened, so bags
with custom types read without any package installed.

Every fault is a :class:`dempath.errors.BagError` whose one-line message names the file and what
is wrong with it: missing path, truncated or corrupt file, no ``metadata.yaml``, a message type
with no definition, a requested topic the bag does not have.
"""

from __future__ import annotations

import heapq
import logging
import struct
import sys
from collections.abc import Callable, Iterable, Iterator, Sequence
from pathlib import Path
from typing import Any, NamedTuple

import yaml  # type: ignore[import-untyped]
from rosbags.interfaces import MessageDefinitionFormat, QosDurability
from rosbags.rosbag2 import Reader, ReaderError, StoragePlugin, Writer, WriterError
from rosbags.typesys import (
    TypesysError,
    get_types_from_idl,
    get_types_from_msg,
)
from rosbags.typesys.store import Typestore

from dempath import mcapread
from dempath.errors import BagError
from dempath.typestore import ensure_type, make_typestore

if sys.version_info >= (3, 14):  # pragma: no cover
    from compression.zstd import ZstdError
else:
    from backports.zstd import ZstdError

LOG = logging.getLogger(__name__)

# What a damaged bag can raise inside rosbags, besides its own ReaderError (lz4 raises
# RuntimeError on bad frames).
READ_FAULTS = (ReaderError, OSError, EOFError, ValueError, KeyError, IndexError, struct.error,
               UnicodeDecodeError, TypesysError, ZstdError, RuntimeError)


class TopicInfo(NamedTuple):
    """One topic of a bag: name, type, message count, ros2msg text or '', whether latched.

    ``latched`` means every recorded publisher offered transient-local durability (a late
    subscriber still gets the last messages), as for camera_info.
    """

    name: str
    msgtype: str
    msgcount: int
    msgdef: str
    latched: bool = False


class RawMessage(NamedTuple):
    """One serialized message: topic, type, bag (receive) time [ns] and its CDR bytes."""

    topic: str
    msgtype: str
    log_time_ns: int
    data: bytes


def _storage_file(path: Path) -> Path:
    """The storage file to name in messages: the bag's single .mcap/.db3, else the bag itself."""
    if path.is_dir():
        files = sorted([*path.glob('*.mcap'), *path.glob('*.db3')])
        if len(files) == 1:
            return files[0]
    return path


def _fast_mcap_files(path: Path) -> list[Path]:
    """The bag's MCAP files if :mod:`dempath.mcapread` can read them all, else []."""
    if path.is_file():
        files = [path] if path.suffix == '.mcap' else []
    else:
        try:
            info = yaml.safe_load((path / 'metadata.yaml').read_text())
            info = info['rosbag2_bagfile_information']
            plain = info['storage_identifier'] == 'mcap' and not info.get('compression_mode')
            files = [path / Path(f).name for f in info['relative_file_paths']] if plain else []
        except (OSError, yaml.YAMLError, KeyError, TypeError):
            files = []
    return files if files and all(mcapread.readable(f) for f in files) else []


def _types_from_definition(msgdef: Any, msgtype: str) -> dict[str, Any]:
    """Parse a connection's ros2msg or ros2idl definition (IDL may hold several sections)."""
    if msgdef.format == MessageDefinitionFormat.MSG and msgdef.data:
        return dict(get_types_from_msg(msgdef.data, msgtype))
    if msgdef.format != MessageDefinitionFormat.IDL or not msgdef.data:
        return {}
    sep = '=' * 80 + '\n'
    sections = [s.split('\n', 1)[1] for s in msgdef.data.split(sep)[1:]] \
        if msgdef.data.startswith(sep + 'IDL: ') else [msgdef.data]
    types: dict[str, Any] = {}
    for idl in sections:
        types.update(get_types_from_idl(idl))
    return types


def _latched(connections: Sequence[Any]) -> bool:
    """Whether every offered QoS profile of these connections is transient local."""
    profiles = [q for c in connections for q in getattr(c.ext, 'offered_qos_profiles', [])]
    return bool(profiles) and all(q.durability == QosDurability.TRANSIENT_LOCAL
                                  for q in profiles)


def _open_reader(path: Path) -> Reader:
    if not path.exists():
        msg = f'{path}: no such bag (neither a bag directory nor a .mcap/.db3 file)'
        raise BagError(msg)
    if path.is_dir() and not (path / 'metadata.yaml').is_file():
        hint = (f'; an interrupted recording? run: dempath bag-recover {path}'
                if any(path.glob('*.mcap')) else '')
        msg = f'{path}: not a rosbag2 bag: no metadata.yaml{hint}'
        raise BagError(msg)
    reader = Reader(path)
    try:
        reader.open()
    except READ_FAULTS as err:
        hint = f'; if it is an interrupted recording, run: dempath bag-recover {path}'
        msg = f'{_storage_file(path)}: truncated or corrupt bag ({err}){hint}'
        raise BagError(msg) from err
    return reader


class BagReader:
    """An open, validated bag; make it with :func:`open_bag`, close it (or use ``with``).

    Attributes:
        path: The bag directory or file.
        topics: Every topic of the bag by name.
        typestore: Store that can deserialize every known type of this bag.
        start_ns: Bag time of the first message [ns].
        end_ns: Bag time just after the last message [ns].
        unknown: Topics whose type has no definition anywhere (raw bytes still readable).
    """

    def __init__(self, path: Path, reader: Reader, typestore: Typestore) -> None:
        self.path = path
        self._reader = reader
        self.typestore = typestore
        self.topics = {
            name: TopicInfo(name, info.msgtype or '', info.msgcount,
                            next((c.msgdef.data for c in info.connections
                                  if c.msgdef.format == MessageDefinitionFormat.MSG), ''),
                            _latched(info.connections))
            for name, info in reader.topics.items()}
        self.start_ns = reader.start_time if reader.message_count else 0
        self.end_ns = reader.end_time if reader.message_count else 0
        self.message_count = reader.message_count
        self.unknown = {t.name: t.msgtype for t in self.topics.values()
                        if not self._register(t, reader.topics[t.name].connections)}
        self._fast_files = _fast_mcap_files(path)

    def _register(self, topic: TopicInfo, connections: Sequence[Any]) -> bool:
        """Register the bag's own definition of the topic's type (ros2msg or ros2idl)."""
        if topic.msgtype not in self.typestore.fielddefs:
            for conn in connections:
                try:
                    self.typestore.register(_types_from_definition(conn.msgdef, conn.msgtype))
                except TypesysError as err:
                    LOG.warning('%s: topic %s: bad definition of %s in the bag: %s',
                                self.path, topic.name, topic.msgtype, err)
        return ensure_type(self.typestore, topic.msgtype)

    def select(self, topics: Sequence[str] = ()) -> list[TopicInfo]:
        """The requested topics (all when empty), checked against the bag.

        Raises:
            BagError: A requested topic is not in the bag (the message lists the ones that are).
        """
        missing = [t for t in topics if t not in self.topics]
        if missing:
            have = ', '.join(sorted(self.topics)) or 'none'
            msg = f'{self.path}: topic {missing[0]} not in bag; topics in the bag: {have}'
            raise BagError(msg)
        return [self.topics[t] for t in (topics or sorted(self.topics))]

    def messages(self, topics: Sequence[str] = (),
                 start_offset_s: float = 0.0) -> Iterator[RawMessage]:
        """Yield the raw messages of ``topics`` (all when empty) in bag-time order.

        Args:
            topics: Topic names to read.
            start_offset_s: Skip messages earlier than bag start + this offset [s].

        Raises:
            BagError: The data is corrupt or truncated (names the file and how far it read).
        """
        wanted = {t.name for t in self.select(topics)}
        conns = [c for c in self._reader.connections if c.topic in wanted]
        if not conns:
            return
        start = self.start_ns + round(start_offset_s * 1e9) if start_offset_s > 0 else None
        count = 0
        try:
            if self._fast_files:
                sources = [mcapread.iter_raw(f, wanted, start) for f in self._fast_files]
                for topic, t_ns, raw in heapq.merge(*sources, key=lambda m: m[1]):
                    count += 1
                    yield RawMessage(topic, self.topics[topic].msgtype, t_ns, raw)
                return
            for conn, t_ns, raw in self._reader.messages(connections=conns, start=start):
                count += 1
                yield RawMessage(conn.topic, conn.msgtype, t_ns, bytes(raw))
        except READ_FAULTS as err:
            msg = f'{_storage_file(self.path)}: corrupt data after {count} messages ({err})'
            raise BagError(msg) from err

    def deserialize(self, message: RawMessage) -> Any:
        """A rosbags message object (numpy arrays for primitive arrays) from a raw message."""
        return self.typestore.deserialize_cdr(message.data, message.msgtype)

    def close(self) -> None:
        """Close the underlying files."""
        self._reader.close()

    def __enter__(self) -> BagReader:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def open_bag(path: str | Path, topics: Sequence[str] = (), *, strict_types: bool = True,
             typestore: Typestore | None = None) -> BagReader:
    """Open and validate a rosbag2 bag (MCAP or sqlite3 directory, or a bare .mcap/.db3 file).

    Args:
        path: Bag directory (with metadata.yaml) or storage file.
        topics: Topics that must be in the bag (empty: no requirement).
        strict_types: Fail when a requested topic's type has no definition in the bag, the
            installed interfaces or the Jazzy store (otherwise it is listed in ``unknown``).
        typestore: Store to extend; a fresh :func:`make_typestore` by default.

    Raises:
        BagError: One line naming the file and the fault.
    """
    path = Path(path)
    reader = _open_reader(path)
    try:
        bag = BagReader(path, reader, typestore or make_typestore())
        selected = bag.select(topics)
        bad = [t for t in selected if t.name in bag.unknown]
        if strict_types and bad:
            msg = (f'{path}: topic {bad[0].name} has unknown message type {bad[0].msgtype} '
                   '(no definition in the bag nor in the installed interfaces)')
            raise BagError(msg)
    except BaseException:
        reader.close()
        raise
    return bag


def write_bag(path: str | Path, messages: Iterable[tuple[str, str, int, Any]], *,
              typestore: Typestore | None = None, storage: str = 'mcap') -> Path:
    """Write a new bag from ``(topic, msgtype, time_ns, message)`` tuples (tests and tools).

    Args:
        path: Bag directory to create (must not exist).
        messages: ``message`` is a rosbags message object or already serialized CDR bytes.
        typestore: Store knowing every type; :func:`make_typestore` by default.
        storage: ``'mcap'`` or ``'sqlite3'``.

    Returns:
        The bag directory.

    Raises:
        BagError: The bag cannot be created or a type is unknown.
    """
    path = Path(path)
    store = typestore or make_typestore()
    plugin = StoragePlugin.MCAP if storage == 'mcap' else StoragePlugin.SQLITE3
    try:
        with Writer(path, version=9, storage_plugin=plugin) as writer:
            conns: dict[str, Any] = {}
            for topic, msgtype, t_ns, message in messages:
                if topic not in conns:
                    ensure_type(store, msgtype)
                    conns[topic] = writer.add_connection(topic, msgtype, typestore=store)
                data = bytes(message) if isinstance(message, bytes | bytearray | memoryview) \
                    else store.serialize_cdr(message, msgtype)
                writer.write(conns[topic], t_ns, data)
    except (WriterError, OSError, KeyError, TypesysError) as err:
        msg = f'{path}: cannot write bag: {err}'
        raise BagError(msg) from err
    return path


def filter_bag(src: str | Path, dst: str | Path,
               keep: Callable[[str, int], bool]) -> Path:
    """Copy a bag to a new MCAP bag with only the messages ``keep(topic, stamp_ns)`` accepts.

    ``stamp_ns`` is the message's header stamp (the camera clock), or its log time for a
    message without a header; the kept messages are copied byte for byte. Used to make a
    recording with a camera missing or frames dropped (tests and fault drills).

    Raises:
        BagError: ``src`` cannot be read or ``dst`` cannot be written.
    """
    with open_bag(src) as reader:
        def kept() -> Iterator[tuple[str, str, int, bytes]]:
            for raw in reader.messages(list(reader.topics)):
                header = getattr(reader.deserialize(raw), 'header', None)
                stamp = (header.stamp.sec * 10**9 + header.stamp.nanosec if header is not None
                         else raw.log_time_ns)
                if keep(raw.topic, stamp):
                    yield raw.topic, raw.msgtype, raw.log_time_ns, bytes(raw.data)

        return write_bag(dst, kept(), typestore=reader.typestore)
