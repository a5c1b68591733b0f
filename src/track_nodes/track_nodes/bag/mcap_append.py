"""Batches of messages into rosbags' MCAP writer at a few C-level passes per batch (the recorder's hot path).

rosbags' ``McapWriter.write`` builds each Message record through a ``BytesIO`` and five
``to_bytes`` calls, and its ``close_chunk`` writes the message index two integers per call;
together they cost the recorder more per message than taking it from DDS. ``append`` adds a batch of
one channel's messages to the pending chunk as ``struct`` headers and the received bytes themselves
(a ``ChunkBuffer`` is a list of blocks: nothing is copied until the chunk is joined once, at its
close), and the ``close_chunk`` installed by ``install`` packs each message index at once. The bytes, the chunk
boundaries (a chunk is closed once it holds more than ``CHUNK_BYTES``), the indexes and every count
are the ones rosbags writes, but for each chunk's CRC, which rosbags leaves at 0 ("not computed") and this
module computes (``test/unit/track_nodes/bag/test_batches.py`` compares the files record by record).
This reaches into rosbags 0.11.9's private McapWriter state, as ``bag.api.flush_mcap_writer`` does;
uncompressed storage only (the recorder never sets compression).
"""

from __future__ import annotations

import struct
import zlib
from bisect import bisect_right
from collections import defaultdict
from collections.abc import Sequence
from functools import partial
from io import BytesIO
from itertools import accumulate, chain, repeat
from typing import Any

CHUNK_BYTES = 2**20  # rosbags closes the pending chunk once it holds more than this
MESSAGE_HEAD = struct.Struct('<BQHIQQ')  # Message record: opcode, length, channel, sequence, log and publish time
RECORD_HEAD = struct.Struct('<BQ')  # opcode, length


class ChunkBuffer:
    """The pending chunk's bytes as blocks, with what rosbags uses of its ``BytesIO`` (``write``, ``tell``,
    ``getvalue``): its schema and channel records land here too, in order."""

    __slots__ = ('blocks', 'size')

    def __init__(self, data: bytes = b'') -> None:
        self.blocks, self.size = ([data] if data else []), len(data)

    def write(self, data) -> int:
        self.blocks.append(bytes(data))  # rosbags passes views of its scratch buffers
        self.size += len(data)
        return len(data)

    def extend(self, blocks: list[bytes], size: int) -> None:
        self.blocks += blocks
        self.size += size

    def tell(self) -> int:
        return self.size

    def getvalue(self) -> bytes:
        return b''.join(self.blocks)


def install(writer: Any) -> None:
    """Make the open rosbags ``Writer``'s storage buffer and close its chunks here (also at its close)."""
    if writer.compression_mode.name != 'NONE':
        raise RuntimeError('bag.mcap_append writes uncompressed chunks only')
    s = writer.storage
    s.chunk.bio = ChunkBuffer(s.chunk.bio.getvalue())
    s.close_chunk = partial(close_chunk, s)


def append(writer: Any, cid: int, stamps: Sequence[int], raws: Sequence[bytes]) -> int:
    """Write the first messages of ``raws`` (log and publish time ``stamps``) to channel ``cid`` until the
    pending chunk is full; → how many were written (at least one). The caller closes a full chunk."""
    s = writer.storage
    chunk = s.chunk
    pos = chunk.bio.tell()
    sizes = [len(r) + 22 for r in raws]  # record length: channel, sequence, two times, data
    starts = list(accumulate([size + 9 for size in sizes[:-1]], initial=pos))  # + opcode and length
    k = max(1, bisect_right(starts, CHUNK_BYTES))  # rosbags writes a message while the chunk holds <= 1 MiB
    ts, rs = stamps[:k], raws[:k]
    parts: list[bytes] = [b''] * (2 * k)
    parts[::2] = map(MESSAGE_HEAD.pack, repeat(5, k), sizes[:k], repeat(cid, k), repeat(0, k), ts, ts)
    parts[1::2] = rs
    if isinstance(chunk.bio, ChunkBuffer):
        chunk.bio.extend(parts, starts[k - 1] + sizes[k - 1] + 9 - pos)
    else:  # a chunk rosbags made (bag.durable's salvage)
        chunk.bio.write(b''.join(parts))
    chunk.msgs[cid].extend(zip(ts, starts[:k], strict=True))
    lo, hi = min(ts), max(ts)
    chunk.message_start_time = min(lo, chunk.message_start_time)
    chunk.message_end_time = max(hi, chunk.message_end_time)
    s.message_start_time, s.message_end_time = min(lo, s.message_start_time), max(hi, s.message_end_time)
    writer.min_timestamp, writer.max_timestamp = min(lo, writer.min_timestamp), max(hi, writer.max_timestamp)
    s.channel_stats[cid] += k
    writer.counts[cid] += k
    return k


def close_chunk(s: Any) -> None:
    """rosbags' ``McapWriter.close_chunk`` (Chunk, its Message Index records, the ChunkIndex kept for the summary)."""
    from rosbags.rosbag2.storage_mcap import PendingChunk

    chunk, bio = s.chunk, s.bio
    size = chunk.bio.tell()
    raw = chunk.bio.getvalue()
    data = s.compressor(raw)
    comp = s.compression.encode()
    # the chunk's CRC-32 of its uncompressed records (rosbags writes 0, "not computed"): a flipped bit is found
    head = struct.pack(f'<QQQII{len(comp)}sQ', chunk.message_start_time, chunk.message_end_time, size,
                       zlib.crc32(raw), len(comp), comp, len(data))
    chunk_start = bio.tell()
    bio.write(RECORD_HEAD.pack(0x06, len(head) + len(data)) + head)
    bio.write(data)
    chunk_end = bio.tell()
    offsets = []
    for cid, msgs in chunk.msgs.items():
        offsets.append((cid, bio.tell()))
        n = 2 * len(msgs)
        bio.write(struct.pack(f'<BQHI{n}Q', 0x07, 6 + 8 * n, cid, 8 * n, *chain.from_iterable(msgs)))
    index = BytesIO()
    index.write(struct.pack('<QQQQI', chunk.message_start_time, chunk.message_end_time, chunk_start,
                            chunk_end - chunk_start, 10 * len(offsets)))
    index.write(b''.join(struct.pack('<HQ', cid, offset) for cid, offset in offsets))
    index.write(struct.pack(f'<QI{len(comp)}sQQ', bio.tell() - chunk_end, len(comp), comp, len(data), size))
    s.chunks.append(index)
    s.chunk = PendingChunk(2**63 - 1, 0, ChunkBuffer(), defaultdict(list))
