"""Fast raw reading of indexed, uncompressed MCAP files: one read per message, no copies.

Written from the MCAP format specification (https://mcap.dev/spec, version 0). The summary
section gives the channels and chunk indexes; each chunk's MessageIndex records give every
message's offset inside the chunk, so a message is read with one ``seek`` + ``read`` from the
file (the page cache) instead of copying whole chunks around. Files whose chunks are compressed
or lack message indexes are not handled here (:func:`readable` says so) and go through rosbags.
"""

from __future__ import annotations

import heapq
import struct
from collections.abc import Iterator
from pathlib import Path
from typing import BinaryIO, NamedTuple

MAGIC = b'\x89MCAP0\r\n'
OP_SCHEMA, OP_CHANNEL, OP_CHUNK_INDEX = 0x03, 0x04, 0x08


class ChunkRef(NamedTuple):
    """Where one uncompressed chunk's records start, and its message index offsets."""

    start_time: int
    records_start: int
    index_offsets: dict[int, int]


class McapIndex(NamedTuple):
    """The summary of one MCAP file: topic of each channel id, and the chunks."""

    topics: dict[int, str]
    chunks: list[ChunkRef]
    compressed: bool


def _string(buf: bytes, pos: int) -> tuple[str, int]:
    (size,) = struct.unpack_from('<I', buf, pos)
    return buf[pos + 4:pos + 4 + size].decode(), pos + 4 + size


def _chunk_ref(content: bytes) -> tuple[ChunkRef, bool]:
    start, _, chunk_start, _, map_len = struct.unpack_from('<QQQQI', content, 0)
    pairs = content[36:36 + map_len]
    offsets = {cid: off for cid, off in struct.iter_unpack('<HQ', pairs)}
    compression, _ = _string(content, 36 + map_len + 8)
    header = 9 + 8 + 8 + 8 + 4 + 4 + len(compression.encode()) + 8
    return ChunkRef(start, chunk_start + header, offsets), bool(compression)


def read_index(stream: BinaryIO) -> McapIndex:
    """Parse the summary section of an MCAP file.

    Raises:
        ValueError: Not an MCAP file, or no summary (e.g. an interrupted recording).
    """
    stream.seek(0)
    if stream.read(8) != MAGIC:
        raise ValueError('not an MCAP file (bad magic)')
    stream.seek(-8 - 29, 2)
    footer = stream.read(37)
    if footer[-8:] != MAGIC or footer[0] != 0x02:
        raise ValueError('no MCAP footer (truncated file?)')
    summary_start, offsets_start, _ = struct.unpack_from('<QQI', footer, 9)
    if not summary_start:
        raise ValueError('MCAP file without summary section')
    stream.seek(summary_start)
    summary = stream.read((offsets_start or stream.seek(0, 2) - 37) - summary_start)
    topics, chunks, compressed, pos = {}, [], False, 0
    while pos + 9 <= len(summary):
        opcode, size = struct.unpack_from('<BQ', summary, pos)
        content = summary[pos + 9:pos + 9 + size]
        if opcode == OP_CHANNEL:
            (channel_id,) = struct.unpack_from('<H', content, 0)
            topics[channel_id], _ = _string(content, 4)
        elif opcode == OP_CHUNK_INDEX:
            ref, is_compressed = _chunk_ref(content)
            chunks.append(ref)
            compressed = compressed or is_compressed or not ref.index_offsets
        pos += 9 + size
    return McapIndex(topics, sorted(chunks), compressed)


def readable(path: Path) -> bool:
    """Whether ``path`` is an MCAP file this module can read (indexed, uncompressed)."""
    try:
        with path.open('rb') as stream:
            index = read_index(stream)
    except (OSError, ValueError, struct.error):
        return False
    return not index.compressed


def _chunk_messages(stream: BinaryIO, chunk: ChunkRef,
                    channels: set[int]) -> list[tuple[int, int, int]]:
    """(log time, absolute record offset, channel id) of the chunk's wanted messages."""
    entries = []
    for channel_id, offset in chunk.index_offsets.items():
        if channel_id not in channels:
            continue
        stream.seek(offset)
        opcode, _, _, length = struct.unpack('<BQHI', stream.read(15))
        if opcode != 0x07:
            raise ValueError(f'no message index at offset {offset}')
        for log_time, rel in struct.iter_unpack('<QQ', stream.read(length)):
            entries.append((log_time, chunk.records_start + rel, channel_id))
    entries.sort()
    return entries


def iter_raw(path: Path, topics: set[str],
             start_ns: int | None = None) -> Iterator[tuple[str, int, bytes]]:
    """Yield ``(topic, log time [ns], CDR bytes)`` of ``topics`` in log-time order.

    Raises:
        ValueError: A record is not where the index says (damaged file).
    """
    with path.open('rb') as stream:
        index = read_index(stream)
        channels = {cid for cid, topic in index.topics.items() if topic in topics}
        lists = [_chunk_messages(stream, c, channels) for c in index.chunks]
        for log_time, offset, channel_id in heapq.merge(*lists):
            if start_ns is not None and log_time < start_ns:
                continue
            stream.seek(offset)
            opcode, length, record_channel = struct.unpack('<BQH', stream.read(11))
            if opcode != 0x05 or record_channel != channel_id:
                raise ValueError(f'no message record at offset {offset}')
            stream.seek(20, 1)
            data = stream.read(length - 22)
            if len(data) != length - 22:
                raise ValueError(f'message at offset {offset} cut short')
            yield index.topics[channel_id], log_time, data
