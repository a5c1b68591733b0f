"""Is every chunk of a bag's .mcap the one that was written? Chunk CRCs checked on read, the bad one named.

Why: a flipped bit in a message payload decodes into a plausible wrong value, and nothing but the chunk's
CRC (which ``bag.writer`` writes into every chunk, as rosbag2 does) tells it from the real one. rosbags
checks the CRC of a chunk it reads, but not of the chunks a query skips, and says only "Chunk checksum
mismatch". ``corrupt_chunk`` reads every chunk record of an .mcap once (the rest is skipped unread),
checks its CRC (decompressing it first if another tool compressed it) and names the first bad one in
one line: the file, the chunk's number and byte offset, its log times. A chunk written without a CRC
(0, older bags) cannot be checked and passes. The bag tools call it for every .mcap of a bag through
``api.open_bag_checked``.
"""

from __future__ import annotations

import struct
from io import BytesIO
from pathlib import Path

MAGIC = b'\x89MCAP0\r\n'
OP_CHUNK, OP_DATA_END = 0x06, 0x0F
RECORD_HEAD = struct.Struct('<BQ')  # opcode, length


def _span(chunk) -> str:
    return f'log times {chunk.message_start_time * 1e-9:.3f} to {chunk.message_end_time * 1e-9:.3f} s'


def corrupt_chunk(mcap: Path) -> str | None:
    """The first chunk of ``mcap`` whose CRC does not hold (or that cannot be read), in one line; None if none.

    Stops at the end of the data section; a file cut short is left to the reader that opens it."""
    from mcap.data_stream import ReadDataStream
    from mcap.exceptions import McapError
    from mcap.records import Chunk
    from mcap.stream_reader import CRCValidationError, get_chunk_data_stream

    number = 0
    with mcap.open('rb') as f:
        if f.read(len(MAGIC)) != MAGIC:
            return None  # not an MCAP file: the reader that opens it says so
        while True:
            pos = f.tell()
            head = f.read(RECORD_HEAD.size)
            if len(head) < RECORD_HEAD.size:
                return None
            op, length = RECORD_HEAD.unpack(head)
            if op == OP_DATA_END:
                return None
            if op != OP_CHUNK:
                f.seek(length, 1)
                continue
            number += 1
            body = f.read(length)
            if len(body) < length:
                return None
            where = f'{mcap}: chunk {number} at byte {pos}'
            try:
                chunk = Chunk.read(ReadDataStream(BytesIO(body)))
                get_chunk_data_stream(chunk, validate_crc=True)
            except CRCValidationError as exc:
                return (f'{where} ({_span(chunk)}) is corrupt: CRC {exc.expected:#010x} stored, '
                        f'{exc.actual:#010x} computed')
            except (McapError, ValueError, struct.error, EOFError, MemoryError) as exc:
                return f'{where} cannot be read: {type(exc).__name__}: {" ".join(str(exc).split())[:200]}'
