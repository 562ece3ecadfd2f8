"""A lean MCAP writer for recording large messages: no copy of message data before the OS.

Written from the MCAP format specification (https://mcap.dev/spec, version 0). A pending chunk
is a list of byte pieces that references each message's data; closing the chunk computes its
CRC-32 over the pieces (zlib-ng, without the GIL on large buffers) and writes them, so a 6 MB
camera frame is copied once, into the OS, instead of four times. Schema and channel records go
straight into the data section (outside chunks) when they are added, so a file cut after any
complete chunk can be read back by a streaming reader (see :mod:`dempath.mcapbag`).

Layout: magic, Header, then Schema / Channel / Chunk (+ its MessageIndex records) in order of
arrival, DataEnd, a summary section (Schema, Channel, ChunkIndex, Statistics records and their
SummaryOffsets), Footer, magic.
"""

from __future__ import annotations

import struct
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import BinaryIO

if sys.version_info >= (3, 14):  # pragma: no cover
    from compression import zstd
else:
    from backports import zstd

try:  # zlib-ng's SIMD CRC-32 is about 4x faster than zlib's on camera frames
    from zlib_ng.zlib_ng import crc32
except ImportError:  # pragma: no cover
    from zlib import crc32

MAGIC = b'\x89MCAP0\r\n'
OP_HEADER, OP_FOOTER, OP_SCHEMA, OP_CHANNEL, OP_MESSAGE = 0x01, 0x02, 0x03, 0x04, 0x05
OP_CHUNK, OP_MESSAGE_INDEX, OP_CHUNK_INDEX, OP_STATISTICS = 0x06, 0x07, 0x08, 0x0B
OP_SUMMARY_OFFSET, OP_DATA_END = 0x0E, 0x0F
_MESSAGE_HEAD = struct.Struct('<BQHIQQ')  # opcode, record length, channel, sequence, times
COMPRESSORS: dict[str, Callable[[bytes], bytes]] = {'': lambda b: b, 'zstd': zstd.compress}


def _string(text: str) -> bytes:
    raw = text.encode()
    return struct.pack('<I', len(raw)) + raw


def _record(opcode: int, content: bytes) -> bytes:
    return struct.pack('<BQ', opcode, len(content)) + content


@dataclass
class _Chunk:
    """Messages of the chunk in progress: byte pieces, size, times and per-channel index."""

    pieces: list[bytes] = field(default_factory=list)
    size: int = 0
    start: int = 2**64 - 1
    end: int = 0
    index: dict[int, list[tuple[int, int]]] = field(default_factory=dict)


class McapStreamWriter:
    """Chunked MCAP writer on an open binary stream (``ros2`` profile by default).

    Args:
        stream: Binary file opened for writing (positioned at 0).
        chunk_size: Uncompressed size that closes a chunk [bytes].
        compression: ``''`` (none) or ``'zstd'``.
    """

    def __init__(self, stream: BinaryIO, chunk_size: int = 4 << 20,
                 compression: str = '') -> None:
        if compression not in COMPRESSORS:
            raise ValueError(f'compression: one of {sorted(COMPRESSORS)}, got {compression!r}')
        self._out = stream
        self._pos = 0
        self.chunk_size = chunk_size
        self.compression = compression
        self._chunk = _Chunk()
        self._schemas: list[bytes] = []
        self._channels: list[bytes] = []
        self._chunk_indexes: list[bytes] = []
        self._counts: dict[int, int] = {}
        self._times = [2**64 - 1, 0]

    def _write(self, *pieces: bytes) -> None:
        for piece in pieces:
            self._out.write(piece)
            self._pos += len(piece)

    def start(self, profile: str = 'ros2', library: str = 'dempath') -> None:
        """Write the magic and the Header record."""
        self._write(MAGIC, _record(OP_HEADER, _string(profile) + _string(library)))

    def add_schema(self, name: str, encoding: str, data: bytes) -> int:
        """Write a Schema record now; return its id (from 1)."""
        schema_id = len(self._schemas) + 1
        content = struct.pack('<H', schema_id) + _string(name) + _string(encoding) + \
            struct.pack('<I', len(data)) + data
        self._schemas.append(_record(OP_SCHEMA, content))
        self._write(self._schemas[-1])
        return schema_id

    def add_channel(self, topic: str, encoding: str, schema_id: int,
                    metadata: dict[str, str]) -> int:
        """Write a Channel record now; return its id (from 1)."""
        channel_id = len(self._channels) + 1
        entries = b''.join(_string(k) + _string(v) for k, v in metadata.items())
        content = struct.pack('<HH', channel_id, schema_id) + _string(topic) + \
            _string(encoding) + struct.pack('<I', len(entries)) + entries
        self._channels.append(_record(OP_CHANNEL, content))
        self._counts[channel_id] = 0
        self._write(self._channels[-1])
        return channel_id

    def add_message(self, channel_id: int, log_time: int, data: bytes, publish_time: int,
                    sequence: int = 0) -> None:
        """Append a Message record to the chunk in progress (the data is not copied)."""
        chunk = self._chunk
        chunk.index.setdefault(channel_id, []).append((log_time, chunk.size))
        head = _MESSAGE_HEAD.pack(OP_MESSAGE, 22 + len(data), channel_id, sequence, log_time,
                                  publish_time)
        chunk.pieces += (head, data)
        chunk.size += len(head) + len(data)
        chunk.start, chunk.end = min(chunk.start, log_time), max(chunk.end, log_time)
        self._counts[channel_id] += 1
        self._times = [min(self._times[0], log_time), max(self._times[1], log_time)]
        if chunk.size >= self.chunk_size:
            self.close_chunk()

    def close_chunk(self) -> None:
        """Write the chunk in progress and its message indexes (nothing if it is empty)."""
        chunk, self._chunk = self._chunk, _Chunk()
        if not chunk.pieces:
            return
        crc = 0
        for piece in chunk.pieces:
            crc = crc32(piece, crc)
        body = chunk.pieces
        if self.compression:
            body = [COMPRESSORS[self.compression](b''.join(chunk.pieces))]
        body_size = sum(len(b) for b in body)
        head = struct.pack('<QQQI', chunk.start, chunk.end, chunk.size, crc) + \
            _string(self.compression) + struct.pack('<Q', body_size)
        chunk_start = self._pos
        self._write(struct.pack('<BQ', OP_CHUNK, len(head) + body_size), head, *body)
        index_start, offsets = self._pos, b''
        for channel_id, entries in chunk.index.items():
            offsets += struct.pack('<HQ', channel_id, self._pos)
            pairs = b''.join(struct.pack('<QQ', t, o) for t, o in entries)
            self._write(_record(OP_MESSAGE_INDEX, struct.pack('<HI', channel_id, len(pairs))
                                + pairs))
        self._chunk_indexes.append(_record(OP_CHUNK_INDEX, struct.pack(
            '<QQQQI', chunk.start, chunk.end, chunk_start, index_start - chunk_start,
            len(offsets)) + offsets + struct.pack('<Q', self._pos - index_start)
            + _string(self.compression) + struct.pack('<QQ', body_size, chunk.size)))

    def flush(self) -> None:
        """Close the chunk in progress and flush the stream to the OS."""
        self.close_chunk()
        self._out.flush()

    def finish(self) -> None:
        """Close the last chunk, then write DataEnd, the summary section and the Footer."""
        self.close_chunk()
        self._write(_record(OP_DATA_END, struct.pack('<I', 0)))
        summary_start = self._pos
        groups = []
        for opcode, records in ((OP_SCHEMA, self._schemas), (OP_CHANNEL, self._channels),
                                (OP_CHUNK_INDEX, self._chunk_indexes)):
            if records:
                groups.append((opcode, self._pos, sum(len(r) for r in records)))
                self._write(*records)
        counts = b''.join(struct.pack('<HQ', c, n) for c, n in sorted(self._counts.items()))
        start, end = (self._times if sum(self._counts.values()) else (0, 0))
        stats = struct.pack('<QHIIIIQQI', sum(self._counts.values()), len(self._schemas),
                            len(self._channels), 0, 0, len(self._chunk_indexes), start, end,
                            len(counts)) + counts
        groups.append((OP_STATISTICS, self._pos, 9 + len(stats)))
        self._write(_record(OP_STATISTICS, stats))
        offsets_start = self._pos
        for opcode, begin, length in groups:
            self._write(_record(OP_SUMMARY_OFFSET, struct.pack('<BQQ', opcode, begin, length)))
        self._write(_record(OP_FOOTER, struct.pack('<QQI', summary_start, offsets_start, 0)),
                    MAGIC)
        self._out.flush()
