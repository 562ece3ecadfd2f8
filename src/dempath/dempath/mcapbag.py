"""rosbag2 MCAP bags written incrementally, and recovery of interrupted ones.

A bag is a directory ``NAME/`` holding ``NAME_0.mcap`` and ``metadata.yaml`` (rosbag2 format 9).
:class:`McapBagWriter` writes the MCAP in chunks (:mod:`dempath.mcapwrite`): schemas are
``ros2msg`` with the full definition text (dependencies included, as Foxglove and
``mcap-ros2-support`` expect) and channels are CDR. :meth:`McapBagWriter.flush` closes the chunk
in progress, so a process killed afterwards leaves every message written up to then readable.

Such a killed recording has no MCAP summary, no footer and no ``metadata.yaml``.
:func:`recover_bag` streams the file record by record up to the first incomplete one, writes a
clean MCAP in its place (the original is kept as ``NAME_0.mcap.broken``) and writes
``metadata.yaml``; :func:`write_metadata` alone rebuilds the metadata of a complete MCAP.
"""

from __future__ import annotations

import logging
import os
import struct
from dataclasses import dataclass, field
from io import BufferedWriter
from pathlib import Path
from typing import Any

import yaml  # type: ignore[import-untyped]
from mcap.exceptions import McapError
from mcap.records import Channel, Message, Schema
from mcap.stream_reader import StreamReader
from rosbags.rosbag2 import ReaderError
from rosbags.rosbag2.metadata import dump_qos_v9
from rosbags.rosbag2.storage_mcap import McapReader
from rosbags.typesys import TypesysError, get_types_from_msg

from dempath.errors import BagError, OutputError
from dempath.mcapwrite import McapStreamWriter
from dempath.typestore import make_typestore

LOG = logging.getLogger(__name__)

COMPRESSIONS = {'none': '', 'zstd': 'zstd'}  # recorder setting -> MCAP chunk compression


def check_output_dir(bag_dir: Path) -> None:
    """Raise :class:`OutputError` unless ``bag_dir`` can be created as a new bag directory."""
    if bag_dir.exists():
        msg = f'{bag_dir}: output bag exists already (choose a new directory)'
        raise OutputError(msg)
    parent = next((p for p in bag_dir.absolute().parents if p.exists()), Path('/'))
    if not parent.is_dir() or not os.access(parent, os.W_OK | os.X_OK):
        msg = f'{bag_dir}: cannot create the output bag: {parent} is not a writable directory'
        raise OutputError(msg)


class McapBagWriter:
    """Writer of one rosbag2 MCAP bag; nothing touches the disk before :meth:`open`.

    Args:
        bag_dir: Bag directory to create.
        chunk_size: Chunk size that closes a chunk by itself [bytes].
        compression: ``'none'`` or ``'zstd'`` (per chunk).
        file_name: Name of the .mcap inside ``bag_dir`` (``<dir name>_0.mcap`` by default).
    """

    def __init__(self, bag_dir: str | Path, chunk_size: int = 4 << 20,
                 compression: str = 'none', file_name: str | None = None) -> None:
        self.bag_dir = Path(bag_dir)
        self.mcap_path = self.bag_dir / (file_name or f'{self.bag_dir.name}_0.mcap')
        self.chunk_size = chunk_size
        self.compression = COMPRESSIONS[compression]
        self._stream: BufferedWriter | None = None
        self._writer: McapStreamWriter | None = None
        self._schemas: dict[str, int] = {}

    def open(self, create_dir: bool = True) -> None:
        """Create the bag directory and start the MCAP file.

        Raises:
            OutputError: The directory exists or cannot be created or written.
        """
        try:
            if create_dir:
                check_output_dir(self.bag_dir)
                self.bag_dir.mkdir(parents=True)
            self._stream = self.mcap_path.open('xb')
        except OSError as err:
            msg = f'{self.bag_dir}: cannot create the output bag: {err.strerror}'
            raise OutputError(msg) from err
        self._writer = McapStreamWriter(self._stream, self.chunk_size, self.compression)
        self._writer.start(profile='ros2', library='dempath')

    def add_topic(self, topic: str, msgtype: str, msgdef: str,
                  offered_qos: str = '') -> int:
        """Register a topic (and its type's schema once); return its channel id.

        Args:
            topic: Topic name.
            msgtype: ``pkg/msg/Name``.
            msgdef: Full ros2msg text with dependencies ('' when unknown: the schema then
                carries only the type name).
            offered_qos: rosbag2 YAML of the publishers' QoS profiles ('' when unknown).
        """
        assert self._writer is not None, 'open() first'
        if msgtype not in self._schemas:
            self._schemas[msgtype] = self._writer.add_schema(msgtype, 'ros2msg', msgdef.encode())
        return self._writer.add_channel(
            topic, 'cdr', self._schemas[msgtype], {'offered_qos_profiles': offered_qos})

    def write(self, channel_id: int, log_time_ns: int, data: bytes,
              publish_time_ns: int = 0, sequence: int = 0) -> None:
        """Append one CDR message (receive time ``log_time_ns``, send time ``publish_time_ns``)."""
        assert self._writer is not None, 'open() first'
        self._writer.add_message(channel_id, log_time_ns, data,
                                 publish_time_ns or log_time_ns, sequence & 0xFFFFFFFF)

    def flush(self) -> None:
        """Close the chunk in progress and hand it to the OS: it survives a SIGKILL from now."""
        if self._writer is not None:
            self._writer.flush()

    def close(self, metadata: bool = True) -> None:
        """Write the MCAP summary and footer, close the file and write ``metadata.yaml``."""
        if self._writer is None or self._stream is None:
            return
        writer, self._writer = self._writer, None
        writer.finish()
        self._stream.close()
        if metadata:
            write_metadata(self.bag_dir)


def _rihs01(msgtype: str, msgdef: str) -> str:
    store = make_typestore()
    try:
        if msgdef and msgtype not in store.fielddefs:
            store.register(get_types_from_msg(msgdef, msgtype))
        return store.hash_rihs01(msgtype)
    except (KeyError, TypesysError):
        return ''


def write_metadata(bag_dir: str | Path) -> dict[str, Any]:
    """(Re)write ``metadata.yaml`` of an MCAP bag from its complete ``*.mcap`` files.

    Returns:
        The ``rosbag2_bagfile_information`` mapping that was written.

    Raises:
        BagError: A .mcap file is missing its summary/footer or is corrupt.
    """
    bag_dir = Path(bag_dir)
    files: list[dict[str, Any]] = []
    topics: dict[str, Any] = {}
    counts: dict[str, int] = {}
    for path in sorted(bag_dir.glob('*.mcap')):
        reader = McapReader(path)
        try:
            reader.open()
        except (ReaderError, OSError, ValueError, struct.error) as err:
            msg = f'{path}: truncated or corrupt MCAP ({err}); run: dempath bag-recover {bag_dir}'
            raise BagError(msg) from err
        meta = reader.metadata
        count = meta.message_count
        start = meta.start_time if count else 0
        files.append({'path': path.name, 'starting_time': {'nanoseconds_since_epoch': start},
                      'duration': {'nanoseconds': max(0, meta.duration - 1)},
                      'message_count': count})
        for conn in reader.connections:
            topics.setdefault(conn.topic, conn)
            counts[conn.topic] = counts.get(conn.topic, 0) + conn.msgcount
        reader.close()
    with_msgs = [f for f in files if f['message_count']]
    start = min((f['starting_time']['nanoseconds_since_epoch'] for f in with_msgs), default=0)
    end = max((f['starting_time']['nanoseconds_since_epoch'] + f['duration']['nanoseconds']
               for f in with_msgs), default=0)
    info = {
        'version': 9, 'storage_identifier': 'mcap',
        'relative_file_paths': [f['path'] for f in files],
        'duration': {'nanoseconds': end - start},
        'starting_time': {'nanoseconds_since_epoch': start},
        'message_count': sum(f['message_count'] for f in files),
        'topics_with_message_count': [
            {'topic_metadata': {'name': name, 'type': conn.msgtype,
                                'serialization_format': 'cdr',
                                'offered_qos_profiles': dump_qos_v9(
                                    conn.ext.offered_qos_profiles),
                                'type_description_hash': _rihs01(conn.msgtype,
                                                                 conn.msgdef.data)},
             'message_count': counts[name]} for name, conn in topics.items()],
        'compression_format': '', 'compression_mode': '', 'files': files,
        'custom_data': None, 'ros_distro': 'jazzy'}
    tmp = bag_dir / 'metadata.yaml.tmp'
    tmp.write_text(yaml.safe_dump({'rosbag2_bagfile_information': info}, sort_keys=False))
    tmp.replace(bag_dir / 'metadata.yaml')
    return info


@dataclass
class RecoveryReport:
    """What :func:`recover_bag` found: per file, messages kept and whether it was rebuilt."""

    bag_dir: Path
    kept: dict[str, int] = field(default_factory=dict)
    rebuilt: list[str] = field(default_factory=list)
    stopped_at: dict[str, str] = field(default_factory=dict)


def _copy_readable(src: Path, dst: McapBagWriter) -> tuple[int, str]:
    """Copy every complete record of ``src`` into ``dst``; return (messages, why it stopped)."""
    channels: dict[int, int] = {}
    schemas: dict[int, Schema] = {}
    count, reason = 0, 'end of file'
    with src.open('rb') as stream:
        try:
            reader = StreamReader(stream, skip_magic=False, emit_chunks=False,
                                  validate_crcs=True)  # a damaged chunk ends the copy
            for record in reader.records:
                if isinstance(record, Schema):
                    schemas[record.id] = record
                elif isinstance(record, Channel) and record.id not in channels:
                    schema = schemas.get(record.schema_id)
                    channels[record.id] = dst.add_topic(
                        record.topic, schema.name if schema else '',
                        schema.data.decode() if schema else '',
                        record.metadata.get('offered_qos_profiles', ''))
                elif isinstance(record, Message) and record.channel_id in channels:
                    dst.write(channels[record.channel_id], record.log_time, record.data,
                              record.publish_time, record.sequence)
                    count += 1
        except (McapError, EOFError, ValueError, struct.error, UnicodeDecodeError) as err:
            reason = f'{type(err).__name__}: {err}'
    return count, reason


def recover_bag(bag_dir: str | Path) -> RecoveryReport:
    """Make an interrupted MCAP recording readable again, keeping every complete chunk.

    A .mcap that opens cleanly is left as it is. A damaged one is copied record by record into
    a clean MCAP of the same name; the original stays beside it as ``*.mcap.broken``. Then
    ``metadata.yaml`` is rewritten from the files.

    Raises:
        BagError: ``bag_dir`` is not a directory with .mcap files.
    """
    bag_dir = Path(bag_dir)
    mcaps = sorted(bag_dir.glob('*.mcap')) if bag_dir.is_dir() else []
    if not mcaps:
        msg = f'{bag_dir}: no .mcap files to recover (expected a bag directory)'
        raise BagError(msg)
    report = RecoveryReport(bag_dir)
    for path in mcaps:
        reader = McapReader(path)
        try:
            reader.open()
            report.kept[path.name] = reader.metadata.message_count
            reader.close()
            continue
        except (ReaderError, OSError, ValueError, struct.error):
            LOG.info('%s: no valid summary/footer; rebuilding from its records', path)
        broken = path.with_name(path.name + '.broken')
        path.replace(broken)
        writer = McapBagWriter(bag_dir, file_name=path.name)
        writer.open(create_dir=False)
        count, reason = _copy_readable(broken, writer)
        writer.close(metadata=False)
        report.kept[path.name] = count
        report.rebuilt.append(path.name)
        report.stopped_at[path.name] = reason
    write_metadata(bag_dir)
    return report
