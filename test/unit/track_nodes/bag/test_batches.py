"""The recorder's batch paths give what the per-message ones gave: the same .mcap records as rosbags'
``Writer.write`` (and each chunk with its CRC, which rosbags leaves at 0), the same loss counts as
``LossCounter.received``."""

from __future__ import annotations

import dataclasses
import random
import zlib

from mcap.records import Chunk
from mcap.stream_reader import StreamReader
from rosbags.rosbag2 import Reader, StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

from track_nodes.bag.api import embed_ros_distro
from track_nodes.bag.durable import open_bag
from track_nodes.bag.loss_count import LossCounter
from track_nodes.bag.mcap_append import CHUNK_BYTES

TYPES = {'/a': 'nav_msgs/msg/Odometry', '/b': 'std_msgs/msg/String', '/late': 'geometry_msgs/msg/PoseStamped'}


def _records(path) -> list:
    """Every record of an .mcap file, chunks whole."""
    with path.open('rb') as f:
        return list(StreamReader(f, emit_chunks=True, record_size_limit=None).records)


def _stream(rng: random.Random, n: int) -> list[tuple[str, int, bytes]]:
    """Messages of several sizes (some past a whole chunk) on /a and /b, /late joining halfway."""
    out = []
    for i in range(n):
        topic = rng.choice(['/a', '/b'] + (['/late'] if i > n // 2 else []))
        size = rng.choice([8, 716, 5000, 40_000] + ([CHUNK_BYTES + 3] if i % 97 == 5 else []))
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


def test_write_many_writes_the_bytes_rosbags_writes(tmp_path):
    rng = random.Random(7)
    ts = get_typestore(Stores.ROS2_JAZZY)
    msgs = _stream(rng, 3000)
    ref = Writer(tmp_path / 'ref' / 'bag', version=9, storage_plugin=StoragePlugin.MCAP)
    ref.open()
    embed_ros_distro(ref)  # as open_bag does: the MCAP's rosbag2 record names jazzy
    bag = open_bag(tmp_path / 'new' / 'bag')
    conns: dict[str, dict] = {'ref': {}, 'new': {}}
    for topic, batch in _runs(msgs, rng):
        for name, writer in (('ref', ref), ('new', bag.writer)):
            if topic not in conns[name]:  # a connection added mid-chunk: its records land in the chunk
                conns[name][topic] = writer.add_connection(topic, TYPES[topic], typestore=ts)
        for _, t, raw in batch:
            ref.write(conns['ref'][topic], t, raw)
        bag.write_many(conns['new'][topic], [t for _, t, _ in batch], tuple(raw for _, _, raw in batch))
    chunks = len(bag.writer.storage.chunks)
    ref.close()
    bag.close()
    assert chunks > 20
    new, ref_records = _records(tmp_path / 'new/bag/bag.mcap'), _records(tmp_path / 'ref/bag/bag.mcap')
    assert len(new) == len(ref_records)
    crcs = 0
    for a, b in zip(new, ref_records, strict=True):
        if isinstance(a, Chunk):  # the same chunk, but for its CRC: computed here, 0 (not computed) in rosbags'
            assert b.uncompressed_crc == 0 and a.uncompressed_crc == zlib.crc32(a.data) != 0
            crcs += 1
            assert dataclasses.replace(a, uncompressed_crc=0) == b
        else:
            assert a == b
    assert crcs >= chunks  # and the one closed at the end
    with Reader(tmp_path / 'new' / 'bag') as reader:
        got = [(c.topic, t, bytes(raw)) for c, t, raw in reader.messages()]
    assert sorted(got, key=lambda m: m[1]) == sorted(msgs, key=lambda m: m[1])


def test_received_many_counts_what_received_counts():
    rng = random.Random(3)
    for _ in range(300):
        seqs: list[int | None] = []
        s = rng.randrange(1, 50)
        for _ in range(rng.randrange(1, 40)):
            s = rng.choice([s + 1] * 8 + [s + rng.randrange(2, 6), rng.randrange(1, 5)])  # runs, gaps, restarts
            seqs.append(None if rng.random() < 0.02 else s)
        one, many, publishers = LossCounter(), LossCounter(), rng.choice([1, 1, 1, 2])
        for c in (one, many):
            c.publishers('/t', publishers)
        cuts = sorted({*rng.sample(range(1, len(seqs)), min(3, len(seqs) - 1)), len(seqs)})
        per_message = [one.received('/t', q) for q in seqs]
        batched = [many.received_many('/t', seqs[a:b]) for a, b in zip([0, *cuts[:-1]], cuts, strict=True)]
        assert sum(batched) == sum(per_message) and many.lost == one.lost and many.last('/t') == one.last('/t')
