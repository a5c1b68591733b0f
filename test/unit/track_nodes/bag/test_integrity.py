"""corrupt_chunk / check_chunks: a flipped bit in any chunk is found by its CRC and named in one line (file,
chunk number, byte offset, log times); an intact bag, and a chunk written without a CRC, pass."""

from __future__ import annotations

import pytest
from rosbags.rosbag2 import StoragePlugin, Writer

from track_nodes.bag.api import BagError, check_chunks, open_bag_checked
from track_nodes.bag.integrity import corrupt_chunk
from track_nodes.bag.typestore import typestore
from track_nodes.bag.writer import CHUNK_BYTES, BagWriter

N = 3 * CHUNK_BYTES // 5000  # about three chunks


def write(path, cls=BagWriter):
    """A bag of raw 5 kB payloads on /raw, by our writer (CRCs) or rosbags' (CRC 0)."""
    w = cls(path).open() if cls is BagWriter else cls(path, version=9, storage_plugin=StoragePlugin.MCAP)
    if cls is not BagWriter:
        w.open()
    conn = w.add_connection('/raw', 'std_msgs/msg/String', typestore=typestore())
    for i in range(N):
        w.write(conn, 10**18 + i * 10**6, i.to_bytes(4, 'little') + bytes(5000))
    w.close()
    return path


def test_an_intact_bag_passes(tmp_path):
    bag = write(tmp_path / 'ok')
    assert corrupt_chunk(bag / 'ok.mcap') is None
    check_chunks(bag)
    open_bag_checked(bag).close()


def test_a_flipped_bit_is_named_in_one_line(tmp_path, flip_bit):
    bag = write(tmp_path / 'bad')
    offset = flip_bit(bag / 'bad.mcap', 2)
    line = corrupt_chunk(bag / 'bad.mcap')
    assert f'chunk 2 at byte {offset}' in line and 'CRC' in line and 'log times' in line and '\n' not in line
    with pytest.raises(BagError, match='chunk 2 at byte') as exc:
        open_bag_checked(bag)
    assert 'track-bag-recover' in str(exc.value)


def test_a_chunk_without_a_crc_cannot_be_checked_and_passes(tmp_path, flip_bit):
    bag = write(tmp_path / 'old', Writer)  # rosbags 0.11 writes CRC 0
    flip_bit(bag / 'old.mcap', 1)
    assert corrupt_chunk(bag / 'old.mcap') is None
