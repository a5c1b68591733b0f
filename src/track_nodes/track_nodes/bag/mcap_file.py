"""``McapFile``: an MCAP writer whose chunks take a batch of messages at a few C-level passes.

Why: the ``mcap`` library's ``Writer.add_message`` builds a ``Message`` record object, updates the
statistics and writes about fifteen ``struct``/``BytesIO`` pieces per message (5-6 µs here), as much as
taking the message from DDS; the recorder cannot keep up with a burst through it, and neither library
has a batch call. This module writes the same file the library's public ``Writer`` writes for the same
calls (uncompressed chunks with CRCs, message indexes, statistics, summary, summary offsets, footer),
byte for byte (``test/unit/track_nodes/bag/test_mcap_file.py``), with the library's public record types
(``mcap.records``) for every record but the two per-message ones, which are packed here in one pass
per batch: a Message record is ``struct`` header + the received bytes (nothing copied until the chunk
is joined once, at its close), a Message Index one ``struct`` call per channel and chunk.

``checkpoint``/``rollback`` serve the recorder's full-disk salvage (``bag.durable``): back to the last
flush, where the file holds complete records only.
"""

from __future__ import annotations

import struct
import zlib
from bisect import bisect_right
from dataclasses import dataclass
from itertools import accumulate, chain, repeat
from typing import IO

MESSAGE_HEAD = struct.Struct('<BQHIQQ')  # Message record: opcode, length, channel, sequence, log and publish time
MESSAGE_OPCODE, MESSAGE_INDEX_OPCODE = 0x05, 0x07


@dataclass(frozen=True)
class Checkpoint:
    """What ``rollback`` returns the file to: its length and the summary's state at a flush."""

    end: int
    chunk_indexes: int
    metadata_indexes: int
    message_count: int
    channel_counts: dict[int, int]
    times: tuple[int, int]


class McapFile:
    """``start``, ``register_schema``/``register_channel``, ``add_messages``, ``add_metadata``, ``flush``,
    ``finish``: the calls and the bytes of ``mcap.writer.Writer(stream, chunk_size, CompressionType.NONE,
    enable_crcs=True)``, with ``add_messages`` for a batch of one channel."""

    def __init__(self, stream: IO[bytes], chunk_size: int) -> None:
        from mcap.data_stream import RecordBuilder

        self.stream, self.chunk_size = stream, chunk_size
        self._records = RecordBuilder()  # the records outside chunks, before they reach the stream
        self.schemas: dict = {}
        self.channels: dict = {}
        self._chunk_indexes: list = []
        self._metadata_indexes: list = []
        self.message_count = 0
        self.channel_counts: dict[int, int] = {}  # the statistics' per-channel counts, in first-message order
        self.start_time = self.end_time = 0
        self._new_chunk()

    # -- records outside the chunks -------------------------------------------------------------------
    def start(self, profile: str, library: str) -> None:
        from mcap.records import Header
        from mcap.writer import MCAP0_MAGIC

        self.stream.write(MCAP0_MAGIC)
        Header(profile, library).write(self._records)
        self._flush_records()

    def register_schema(self, name: str, encoding: str, data: bytes) -> int:
        from mcap.records import Schema

        schema = Schema(id=len(self.schemas) + 1, data=data, encoding=encoding, name=name)
        self.schemas[schema.id] = schema
        self._chunk_record(schema)
        return schema.id

    def register_channel(self, topic: str, message_encoding: str, schema_id: int, metadata: dict) -> int:
        from mcap.records import Channel

        channel = Channel(id=len(self.channels) + 1, topic=topic, message_encoding=message_encoding,
                          schema_id=schema_id, metadata=metadata)
        self.channels[channel.id] = channel
        self._chunk_record(channel)
        return channel.id

    def add_metadata(self, name: str, data: dict[str, str]) -> None:
        from mcap.records import Metadata, MetadataIndex

        self._flush_records()
        offset = self.stream.tell()
        Metadata(name=name, metadata=data).write(self._records)
        self._metadata_indexes.append(MetadataIndex(offset=offset, length=self._records.count, name=name))
        self._flush_records()

    # -- messages ---------------------------------------------------------------------------------------
    def add_messages(self, channel_id: int, stamps, raws) -> None:
        """Messages ``raws`` of ``channel_id`` with log and publish time ``stamps`` [ns], sequence 0, in order;
        a chunk is closed after the message that takes it past ``chunk_size``, as the library's writer does."""
        n, done = len(raws), 0
        sizes = [len(r) + 22 for r in raws]  # record length: channel, sequence, two times, data
        counts = self.channel_counts
        if n and channel_id not in counts:
            counts[channel_id] = 0
        while done < n:
            # the library's writer closes the chunk after the message that ends past chunk_size
            at = list(accumulate((s + 9 for s in sizes[done:]), initial=self._chunk_size))  # record starts, then end
            k = min(n - done, bisect_right(at, self.chunk_size, 1))
            ts, rs = list(stamps[done:done + k]), raws[done:done + k]
            parts: list = [b''] * (2 * k)
            parts[::2] = map(MESSAGE_HEAD.pack, repeat(MESSAGE_OPCODE, k), sizes[done:done + k], repeat(channel_id, k),
                             repeat(0, k), ts, ts)
            parts[1::2] = rs
            self._blocks += parts
            self._chunk_size = at[k]
            self._index.setdefault(channel_id, []).extend(chain.from_iterable(zip(ts, at[:k], strict=True)))
            lo, hi = min(ts), max(ts)
            self.start_time = lo if self.message_count == 0 else min(lo, self.start_time)
            self.end_time = max(hi, self.end_time)
            self._chunk_times = (lo, hi) if self._chunk_messages == 0 else (
                min(lo, self._chunk_times[0]), max(hi, self._chunk_times[1]))
            self._chunk_messages += k
            self.message_count += k
            counts[channel_id] += k
            done += k
            if self._chunk_size > self.chunk_size:
                self._close_chunk()

    # -- writing out ------------------------------------------------------------------------------------
    def flush(self) -> None:
        """Close the pending chunk (if it holds a message) and hand the file's bytes to the OS."""
        self._close_chunk()
        self._flush_records()
        self.stream.flush()

    @property
    def chunks(self) -> int:
        """Chunks written so far."""
        return len(self._chunk_indexes)

    def checkpoint(self) -> Checkpoint:
        """After ``flush``: the state ``rollback`` returns to."""
        return Checkpoint(self.stream.tell(), len(self._chunk_indexes), len(self._metadata_indexes),
                          self.message_count, dict(self.channel_counts), (self.start_time, self.end_time))

    def rollback(self, to: Checkpoint, stream: IO[bytes]) -> None:
        """Continue on ``stream`` (the file reopened) cut back to ``to``: the pending chunk and everything after
        the checkpoint are gone; schemas and channels stay registered (the summary repeats them)."""
        stream.truncate(to.end)
        stream.seek(to.end)
        self.stream = stream
        del self._chunk_indexes[to.chunk_indexes:], self._metadata_indexes[to.metadata_indexes:]
        self.message_count, self.channel_counts = to.message_count, dict(to.channel_counts)
        self.start_time, self.end_time = to.times
        self._records.end()
        self._new_chunk()

    def summary_bytes(self) -> int:
        """About what ``finish`` will write (for a disk reserve)."""
        size = sum(len(s.name) + len(s.encoding) + len(s.data) + 32 for s in self.schemas.values())
        size += sum(len(c.topic) + len(c.message_encoding) + 64 + sum(map(len, chain(*c.metadata.items())))
                    for c in self.channels.values())
        return size + len(self._chunk_indexes) * (60 + 10 * len(self.channels)) + 10 * len(self.channels) + 512

    def finish(self) -> None:
        """The last chunk, Data End, the summary (schemas, channels, statistics, chunk and metadata indexes, the
        summary offsets) and the footer with the summary's CRC; the stream stays open."""
        from mcap.data_stream import RecordBuilder
        from mcap.opcode import Opcode
        from mcap.records import DataEnd, Footer, Statistics, SummaryOffset
        from mcap.writer import MCAP0_MAGIC

        self._close_chunk()
        DataEnd(0).write(self._records)
        self._flush_records()
        start = self.stream.tell()
        summary = RecordBuilder()
        offsets = []
        stats = Statistics(attachment_count=0, channel_count=len(self.channels),
                           channel_message_counts=self.channel_counts, chunk_count=len(self._chunk_indexes),
                           message_count=self.message_count,
                           message_end_time=self.end_time, message_start_time=self.start_time,
                           metadata_count=len(self._metadata_indexes), schema_count=len(self.schemas))
        for opcode, group in ((Opcode.SCHEMA, self.schemas.values()), (Opcode.CHANNEL, self.channels.values()),
                              (Opcode.STATISTICS, [stats]), (Opcode.CHUNK_INDEX, self._chunk_indexes),
                              (Opcode.ATTACHMENT_INDEX, []), (Opcode.METADATA_INDEX, self._metadata_indexes)):
            group_start = summary.count
            for record in group:
                record.write(summary)
            offsets.append(SummaryOffset(group_opcode=opcode, group_start=start + group_start,
                                         group_length=summary.count - group_start))
        offset_start = start + summary.count
        for offset in offsets:
            offset.write(summary)
        data = summary.end()
        crc = zlib.crc32(struct.pack('<BQQQ', Opcode.FOOTER, 20, start, offset_start), zlib.crc32(data))
        self.stream.write(data)
        Footer(summary_start=start, summary_offset_start=offset_start, summary_crc=crc).write(self._records)
        self._flush_records()
        self.stream.write(MCAP0_MAGIC)

    # -- chunks -----------------------------------------------------------------------------------------
    def _new_chunk(self) -> None:
        from mcap.data_stream import RecordBuilder

        self._chunk_builder = RecordBuilder()  # schema and channel records of the chunk, before its messages
        self._blocks: list = []
        self._chunk_size = 0
        self._chunk_messages = 0
        self._chunk_times = (0, 0)
        self._index: dict[int, list[int]] = {}  # channel -> [log time, offset, ...] (first-message order)

    def _chunk_record(self, record) -> None:
        """A schema or channel record into the pending chunk (a chunk past ``chunk_size`` is closed)."""
        record.write(self._chunk_builder)
        self._blocks.append(self._chunk_builder.end())
        self._chunk_size += len(self._blocks[-1])
        if self._chunk_size > self.chunk_size:
            self._close_chunk()

    def _close_chunk(self) -> None:
        from mcap.records import ChunkIndex

        if self._chunk_messages == 0:
            return
        data = b''.join(self._blocks)
        lo, hi = self._chunk_times
        self._flush_records()
        chunk_start = self.stream.tell()
        head = struct.pack('<QQQIIQ', lo, hi, len(data), zlib.crc32(data), 0, len(data))  # no compression
        self.stream.write(struct.pack('<BQ', 0x06, len(head) + len(data)) + head)
        self.stream.write(data)
        index_start = chunk_start + 9 + len(head) + len(data)
        offsets, pieces, at = {}, [], index_start
        for cid, flat in self._index.items():
            offsets[cid] = at
            pieces.append(struct.pack(f'<BQHI{len(flat)}Q', MESSAGE_INDEX_OPCODE, 6 + 8 * len(flat), cid, 8 * len(flat),
                                      *flat))
            at += len(pieces[-1])
        self.stream.write(b''.join(pieces))
        self._chunk_indexes.append(ChunkIndex(
            message_start_time=lo, message_end_time=hi, chunk_start_offset=chunk_start,
            chunk_length=index_start - chunk_start, message_index_offsets=offsets,
            message_index_length=at - index_start, compression='', compressed_size=len(data),
            uncompressed_size=len(data)))
        self._new_chunk()

    def _flush_records(self) -> None:
        self.stream.write(self._records.end())

