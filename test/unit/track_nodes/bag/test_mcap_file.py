"""``McapFile`` writes the bytes the ``mcap`` library's public ``Writer`` writes for the same calls, batch by
batch; ``DurableBag`` over it gives a bag that rosbags and the mcap reader read whole, every chunk with its CRC."""

from __future__ import annotations

import io
import random
import zlib

import pytest
from mcap.reader import make_reader
from mcap.records import Chunk
from mcap.stream_reader import StreamReader
from mcap.writer import CompressionType, Writer
from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_typestore

from track_nodes.bag.durable import open_bag
from track_nodes.bag.mcap_file import McapFile
from track_nodes.bag.writer import CHUNK_BYTES

TYPES = {'/a': 'nav_msgs/msg/Odometry', '/b': 'std_msgs/msg/String', '/late': 'geometry_msgs/msg/PoseStamped'}


def _stream(rng: random.Random, n: int, chunk: int) -> list[tuple[str, int, bytes]]:
    """Messages of several sizes (some past a whole chunk) on /a and /b, /late joining halfway."""
    out = []
    for i in range(n):
        topic = rng.choice(['/a', '/b'] + (['/late'] if i > n // 2 else []))
        size = rng.choice([0, 8, 716, 5000, chunk // 20] + ([chunk + 3] if i % 97 == 5 else []))
        out.append((topic, 10**18 + rng.randrange(10**9), rng.randbytes(size)))
    return out


def _runs(msgs, rng: random.Random):
    """Consecutive messages of one topic, cut into batches of random length (as the recorder takes them)."""
    i = 0
    while i < len(msgs):
        j = i + 1
        while j < len(msgs) and msgs[j][0] == msgs[i][0] and j - i < rng.randrange(1, 400):
            j += 1
        yield msgs[i][0], msgs[i:j]
        i = j


@pytest.mark.parametrize(('seed', 'chunk'), [(7, CHUNK_BYTES), (8, 50_000), (9, 3000)])
def test_the_bytes_of_the_public_writer(seed, chunk):
    rng = random.Random(seed)
    msgs = _stream(rng, 3000, chunk)
    ref_out, new_out = io.BytesIO(), io.BytesIO()
    ref = Writer(ref_out, chunk_size=chunk, compression=CompressionType.NONE, enable_crcs=True)
    new = McapFile(new_out, chunk)
    ref.start('ros2', 'lib')
    new.start('ros2', 'lib')
    channels: dict[str, int] = {}
    for k, (topic, batch) in enumerate(_runs(msgs, rng)):
        if topic not in channels:  # schema and channel records mid-chunk, as a topic found later gives them
            ids = [w.register_schema(TYPES[topic], 'ros2msg', topic.encode() * 50) for w in (ref, new)]
            cids = [w.register_channel(topic, 'cdr', i, {'q': topic}) for w, i in zip((ref, new), ids, strict=True)]
            assert ids[0] == ids[1] and cids[0] == cids[1]
            channels[topic] = cids[0]
        for _, t, raw in batch:
            ref.add_message(channels[topic], t, raw, t)
        new.add_messages(channels[topic], [t for _, t, _ in batch], [raw for _, _, raw in batch])
        if k % 37 == 36:  # the recorder's timed flushes
            ref.flush()
            new.flush()
    for w in (ref, new):
        w.add_metadata('rosbag2', {'serialized_metadata': 'x: 1'})
        w.finish()
    assert new.chunks > 10
    assert new_out.getvalue() == ref_out.getvalue()


def test_durable_bag_reads_back_whole(tmp_path):
    rng = random.Random(3)
    ts = get_typestore(Stores.ROS2_JAZZY)
    msgs = _stream(rng, 2000, CHUNK_BYTES)
    bag = open_bag(tmp_path / 'bag')
    conns = {}
    for topic, batch in _runs(msgs, rng):
        if topic not in conns:
            conns[topic] = bag.writer.add_connection(topic, TYPES[topic], typestore=ts)
        bag.write_many(conns[topic], [t for _, t, _ in batch], tuple(raw for _, _, raw in batch))
    chunks = bag.writer.chunks
    bag.close()
    assert chunks > 20 and not (tmp_path / 'bag' / '.disk-reserve').exists()
    with (tmp_path / 'bag' / 'bag.mcap').open('rb') as f:
        records = list(StreamReader(f, emit_chunks=True, record_size_limit=None).records)
    crcs = [c for c in records if isinstance(c, Chunk)]
    assert len(crcs) > chunks and all(c.uncompressed_crc == zlib.crc32(c.data) != 0 for c in crcs)
    with Reader(tmp_path / 'bag') as reader:
        got = [(c.topic, t, bytes(raw)) for c, t, raw in reader.messages()]
    assert sorted(got, key=lambda m: m[1]) == sorted(msgs, key=lambda m: m[1])
    with (tmp_path / 'bag' / 'bag.mcap').open('rb') as f:
        n = sum(1 for _ in make_reader(f, validate_crcs=True).iter_messages())
    assert n == len(msgs)


def test_rollback_returns_to_the_checkpoint(tmp_path):
    rng = random.Random(5)
    ts = get_typestore(Stores.ROS2_JAZZY)
    bag = open_bag(tmp_path / 'bag')
    conn = bag.writer.add_connection('/a', TYPES['/a'], typestore=ts)
    kept = [(10**18 + i, rng.randbytes(700)) for i in range(500)]
    bag.write_many(conn, [t for t, _ in kept], [r for _, r in kept])
    bag.flush()
    bag.write_many(conn, [2 * 10**18 + i for i in range(300)], [rng.randbytes(900) for _ in range(300)])
    bag.fail(OSError(28, 'No space left on device'))
    assert bag.failed[1] and bag.written() == 500
    with Reader(tmp_path / 'bag') as reader:
        got = [(t, bytes(raw)) for _, t, raw in reader.messages()]
        assert reader.message_count == 500
    assert got == kept
