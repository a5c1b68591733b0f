"""``track-bag-recover BROKEN_BAG [OUT]``: rebuild a complete bag from a killed recorder's .mcap.

When the recorder is killed (SIGKILL, power loss, OOM), its bag directory holds an .mcap
without summary and footer and no ``metadata.yaml``; ``track-play`` and rosbags refuse it.
The recorder flushes every ``flush_period`` (default 1 s), so the file still holds every
message up to the last flush. To get them back::

    track-bag-recover bags/run1              # writes bags/run1-recovered/
    track-bag-recover bags/run1 bags/fixed   # or choose the output bag
    track-play bags/run1-recovered

``BROKEN_BAG`` is the bag directory or its .mcap file. The .mcap is read with the mcap
library's stream reader, record by record (chunks are unpacked), up to the truncation point;
if the last chunk is cut off, the complete messages inside it are salvaged too (uncompressed
chunks only). A chunk whose CRC does not hold (a flipped bit) is skipped and counted, so the
other chunks of a damaged bag can be recovered too. Every complete message is written, with its
schema, topic, type, offered QoS and log time, to a new bag (``bag.writer``: rosbag2 version 9,
MCAP). The original is left untouched. Prints the messages recovered per topic. A bad path, an
unreadable file or an output that cannot be written → one line on stderr, exit 2; a file with no
complete message in it → one line, exit 1, and no bag written.
"""

from __future__ import annotations

import argparse
import shutil
import struct
import sys
from collections.abc import Sequence
from dataclasses import dataclass, field
from io import BytesIO
from pathlib import Path

from track_nodes.base import EXIT_BAD_INPUT

PROG = 'track-bag-recover'
MAGIC = b'\x89MCAP0\r\n'
OP_SCHEMA, OP_CHANNEL, OP_MESSAGE, OP_CHUNK = 0x03, 0x04, 0x05, 0x06


class RecoverError(ValueError):
    """One line naming the file and the problem."""


@dataclass
class Recovered:
    """What was read from a broken .mcap."""

    schemas: dict[int, tuple[str, str, str]] = field(default_factory=dict)  # id → (name, encoding, data)
    channels: dict[int, tuple[int, str, str, dict]] = field(default_factory=dict)  # id → (schema, topic, enc, meta)
    messages: list[tuple[int, int, bytes]] = field(default_factory=list)  # (channel id, log_time, data)
    stop_reason: str = ''
    stop_offset: int | None = None
    corrupt_chunks: int = 0  # skipped: their CRC does not hold


class NothingRecoveredError(RecoverError):
    """The file holds no complete message (exit 1)."""


EXIT_NOTHING = 1


def read_broken_mcap(path: Path) -> Recovered:
    """Every complete schema, channel and message of ``path``, up to where the file is cut."""
    from mcap.exceptions import McapError
    from mcap.records import Chunk
    from mcap.stream_reader import StreamReader

    out = Recovered()
    with path.open('rb') as f:
        head = f.read(len(MAGIC))
        if not head:
            raise RecoverError(f'{path}: empty file (the recorder died before its first flush): nothing to recover')
        if head != MAGIC:
            raise RecoverError(f'{path}: not an MCAP file (bad magic)')
        f.seek(0)
        try:
            for record in StreamReader(f, emit_chunks=True, record_size_limit=None).records:
                for inner in _unpack(record, out) if isinstance(record, Chunk) else [record]:
                    _add(inner, out)
            out.stop_reason = 'complete file, footer reached' + _skipped(out)
            return out
        except (McapError, struct.error, ValueError, EOFError) as exc:
            out.stop_reason = f'cut at the first incomplete record ({type(exc).__name__})' + _skipped(out)
    _salvage_tail(path, out)
    return out


def _unpack(chunk, out: Recovered) -> list:
    """The records of a chunk whose CRC holds; [] (counted) for one that does not, or that does not parse."""
    from mcap.exceptions import McapError
    from mcap.stream_reader import breakup_chunk

    try:
        return breakup_chunk(chunk, validate_crc=True)
    except (McapError, struct.error, ValueError, EOFError):  # CRCValidationError is a ValueError
        out.corrupt_chunks += 1
        return []


def _skipped(out: Recovered) -> str:
    return f'; {out.corrupt_chunks} corrupt chunk(s) skipped (CRC mismatch)' if out.corrupt_chunks else ''


def _add(record, out: Recovered) -> None:
    from mcap.records import Channel, Message, Schema

    if isinstance(record, Schema):
        out.schemas[record.id] = (record.name, record.encoding, record.data.decode())
    elif isinstance(record, Channel):
        out.channels[record.id] = (record.schema_id, record.topic, record.message_encoding, dict(record.metadata))
    elif isinstance(record, Message):
        out.messages.append((record.channel_id, record.log_time, bytes(record.data)))


def _salvage_tail(path: Path, out: Recovered) -> None:
    """If the file ends inside an uncompressed chunk, add the complete records inside it.

    The stream reader drops a cut-off chunk as a whole; its leading records may be complete.
    """
    data = path.read_bytes()
    pos = len(MAGIC)
    while pos + 9 <= len(data):
        op, (length,) = data[pos], struct.unpack_from('<Q', data, pos + 1)
        if pos + 9 + length <= len(data):
            pos += 9 + length
            continue
        out.stop_offset = pos
        if op == OP_CHUNK:
            before = len(out.messages)
            _salvage_chunk(memoryview(data)[pos + 9:], out)
            if len(out.messages) > before:
                out.stop_reason += f'; {len(out.messages) - before} messages salvaged from the cut-off chunk'
        return
    out.stop_offset = pos


def _salvage_chunk(body: memoryview, out: Recovered) -> None:
    """Complete schema/channel/message records at the start of a cut-off chunk record body."""
    from mcap.data_stream import ReadDataStream
    from mcap.exceptions import McapError
    from mcap.records import Channel, Message, Schema

    # message_start_time u64, message_end_time u64, uncompressed_size u64, crc u32,
    # compression string (u32 length + bytes), records byte array (u64 length + bytes)
    try:
        (clen,) = struct.unpack_from('<I', body, 28)
        if bytes(body[32:32 + clen]):
            return  # compressed: a cut-off compressed chunk cannot be decoded
        pos = 32 + clen + 8
    except struct.error:
        return
    readers = {OP_SCHEMA: lambda s, n: Schema.read(s), OP_CHANNEL: lambda s, n: Channel.read(s),
               OP_MESSAGE: Message.read}
    while pos + 9 <= len(body):
        op, (length,) = body[pos], struct.unpack_from('<Q', body, pos + 1)
        end = pos + 9 + length
        if end > len(body):
            return
        if op in readers:
            try:
                _add(readers[op](ReadDataStream(BytesIO(bytes(body[pos + 9:end]))), length), out)
            except (McapError, ValueError, struct.error, EOFError):
                return
        pos = end


def write_recovered(rec: Recovered, out_path: Path) -> dict[str, int]:
    """Write ``rec`` as a complete rosbag2 bag at ``out_path`` (``bag.writer``); → messages per topic."""
    from rosbags.rosbag2.metadata import parse_qos
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    from track_nodes.bag.writer import BagWriter

    typestore = get_typestore(Stores.ROS2_JAZZY)
    counts: dict[str, int] = {}
    conns = {}
    writer = BagWriter(out_path).open()
    for cid, (schema_id, topic, encoding, meta) in sorted(rec.channels.items()):
        name, _, text = rec.schemas.get(schema_id, ('', '', ''))
        if not name:
            continue
        try:
            qos = parse_qos(meta.get('offered_qos_profiles', ''))
        except Exception:  # QoS is optional information
            qos = []
        if name not in typestore.fielddefs and text:
            # A type our typestore does not know: learn it from the embedded schema.
            typestore.register({k: v for k, v in get_types_from_msg(text, name).items()
                                if k not in typestore.fielddefs})
        conns[cid] = writer.add_connection(topic, name, serialization_format=encoding or 'cdr',
                                           offered_qos_profiles=qos, typestore=typestore)
        counts[topic] = 0
    for cid, t, data in sorted(rec.messages, key=lambda m: m[1]):
        conn = conns.get(cid)
        if conn is None:
            continue
        writer.write(conn, t, data)
        counts[conn.topic] += 1
    writer.close()
    return counts


def find_mcap(path: Path) -> Path:
    if not path.exists():
        raise RecoverError(f'{path}: no such file or directory')
    if path.is_file():
        return path
    if not path.is_dir():
        raise RecoverError(f'{path}: not a regular file or directory (a FIFO or device is refused)')
    files = sorted(path.glob('*.mcap'))
    if not files:
        raise RecoverError(f'{path}: no .mcap file in this directory (not a bag)')
    if len(files) > 1:
        raise RecoverError(f'{path}: several .mcap files ({", ".join(f.name for f in files)}); give one')
    if not files[0].is_file():
        raise RecoverError(f'{files[0]}: not a regular file (a FIFO, device or directory is refused)')
    return files[0]


def recoverable(rec: Recovered) -> int:
    """Messages of ``rec`` on a channel whose schema was read: what ``write_recovered`` writes."""
    ok = {cid for cid, (sid, *_) in rec.channels.items() if rec.schemas.get(sid, ('',))[0]}
    return sum(1 for cid, _, _ in rec.messages if cid in ok)


def recover(broken: Path, out: Path | None = None) -> tuple[Path, dict[str, int], Recovered]:
    mcap = find_mcap(broken)
    bag_dir = broken if broken.is_dir() else broken.parent
    out = out if out is not None else bag_dir.with_name(bag_dir.name + '-recovered')
    if out.exists():
        raise RecoverError(f'{out}: exists already, not overwriting (give another OUT)')
    try:
        rec = read_broken_mcap(mcap)
    except OSError as exc:
        raise RecoverError(f'{mcap}: cannot read: {exc.strerror or exc}') from None
    if not recoverable(rec):
        raise NothingRecoveredError(f'{mcap}: nothing to recover: no complete message in it ({rec.stop_reason}); '
                               'no bag written')
    try:
        counts = write_recovered(rec, out)
    except OSError as exc:
        if out.is_dir():
            shutil.rmtree(out, ignore_errors=True)  # ours, and incomplete
        raise RecoverError(f'{out}: cannot write the recovered bag: {exc.strerror or exc}') from None
    return out, counts, rec


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog=PROG, description=__doc__.split('\n\n')[0].split(': ', 1)[1],
                                 formatter_class=argparse.RawDescriptionHelpFormatter,
                                 epilog=__doc__.split('\n\n', 1)[1])
    ap.error = lambda message: ap.exit(EXIT_BAD_INPUT, f'{PROG}: {message}\n')  # one line
    ap.add_argument('broken', type=Path, metavar='BROKEN_BAG', help='bag directory or .mcap of a killed recorder')
    ap.add_argument('out', type=Path, nargs='?', default=None, metavar='OUT',
                    help='output bag (default: <BROKEN_BAG>-recovered)')
    args = ap.parse_args(sys.argv[1:] if argv is None else list(argv))
    try:
        out, counts, rec = recover(args.broken, args.out)
    except RecoverError as exc:
        print(f'{PROG}: {exc}', file=sys.stderr)
        return EXIT_NOTHING if isinstance(exc, NothingRecoveredError) else EXIT_BAD_INPUT
    total = sum(counts.values())
    print(f'{PROG}: read {args.broken} ({rec.stop_reason})')
    for topic, n in sorted(counts.items()):
        print(f'  {topic}: {n} messages recovered')
    print(f'{PROG}: {total} messages recovered to {out}')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
