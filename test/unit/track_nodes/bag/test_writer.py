"""BagWriter: a rosbag2 v9 bag through the mcap library's public writer, read back by rosbags, the mcap reader
(with the schemas the file embeds) and rclpy alike; every chunk carries a CRC that holds."""

from __future__ import annotations

import re

import pytest
import yaml
from mcap.reader import make_reader
from mcap.records import Chunk
from mcap.stream_reader import StreamReader
from mcap_ros2.decoder import DecoderFactory
from nav_msgs.msg import Odometry
from rclpy.qos import DurabilityPolicy, QoSProfile
from rclpy.serialization import deserialize_message, serialize_message
from rosbags.rosbag2 import Reader
from std_msgs.msg import String

from track_nodes.bag.api import qos_to_rosbags
from track_nodes.bag.typestore import typestore
from track_nodes.bag.writer import CHUNK_BYTES, BagWriter

LATCHED = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)


def _odom(i: int) -> bytes:
    m = Odometry()
    m.child_frame_id = f'msg{i}'
    m.header.frame_id = 'map' + ' ' * 3000  # 3.7 kB: a few hundred fill a chunk
    return serialize_message(m)


ODOMS = [_odom(i) for i in range(600)]  # serialized once: CDR padding bytes may differ between serializations


@pytest.fixture
def bag(tmp_path):
    w = BagWriter(tmp_path / 'b').open()
    ts = typestore()
    odom = w.add_connection('/odom', 'nav_msgs/msg/Odometry', typestore=ts,
                            offered_qos_profiles=[qos_to_rosbags(LATCHED)])
    text = w.add_connection('/text', 'std_msgs/msg/String', typestore=ts)
    for i in range(600):
        w.write(odom, 10**18 + i, ODOMS[i])
        if i % 100 == 0:
            w.write_many(text, [10**18 + i] * 2, [serialize_message(String(data=f's{i}'))] * 2)
    w.set_custom_data('note', 'kept')
    w.close()
    return tmp_path / 'b'


def test_rosbag2_layout(bag):
    with (bag / 'b.mcap').open('rb') as f:
        reader = make_reader(f)
        header, summary = reader.get_header(), reader.get_summary()
        records = {m.name: m.metadata for m in reader.iter_metadata()}
    assert header.profile == 'ros2'
    assert sorted((s.name, s.encoding) for s in summary.schemas.values()) == [
        ('nav_msgs/msg/Odometry', 'ros2msg'), ('std_msgs/msg/String', 'ros2msg')]
    channels = {c.topic: c for c in summary.channels.values()}
    assert {c.message_encoding for c in channels.values()} == {'cdr'}
    assert 'durability: transient_local' in channels['/odom'].metadata['offered_qos_profiles']
    assert summary.statistics.message_count == 612 and summary.statistics.chunk_count > 1
    assert re.search(r'ros_distro: jazzy', records['rosbag2']['serialized_metadata'])
    meta = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert (meta['version'], meta['storage_identifier'], meta['ros_distro']) == (9, 'mcap', 'jazzy')
    assert meta['custom_data'] == {'note': 'kept'} and meta['message_count'] == 612
    assert meta['starting_time']['nanoseconds_since_epoch'] == 10**18 and meta['duration']['nanoseconds'] == 599
    topics = {t['topic_metadata']['name']: t for t in meta['topics_with_message_count']}
    assert topics['/odom']['message_count'] == 600 and topics['/text']['message_count'] == 12
    assert topics['/odom']['topic_metadata']['type_description_hash'].startswith('RIHS01_')


def test_three_decoders_agree_on_every_message(bag):
    with Reader(bag) as reader:
        by_rosbags = [(c.topic, t, bytes(raw)) for c, t, raw in reader.messages()]
    with (bag / 'b.mcap').open('rb') as f:
        by_mcap = [(ch.topic, m.log_time, m.data, d) for _, ch, m, d in
                   make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages()]
    assert [m[:3] for m in by_mcap] == by_rosbags
    odoms = [(raw, d) for topic, _, raw, d in by_mcap if topic == '/odom']
    assert [d.child_frame_id for _, d in odoms] == [f'msg{i}' for i in range(600)]
    assert [deserialize_message(raw, Odometry).child_frame_id for raw, _ in odoms] == [f'msg{i}' for i in range(600)]
    assert [raw for raw, _ in odoms] == ODOMS  # the bytes as given


def test_every_chunk_has_a_crc_that_holds(bag):
    with (bag / 'b.mcap').open('rb') as f:
        chunks = [r for r in StreamReader(f, emit_chunks=True, validate_crcs=True).records if isinstance(r, Chunk)]
    assert len(chunks) >= 2 and all(c.uncompressed_crc != 0 for c in chunks)
    assert all(c.uncompressed_size <= CHUNK_BYTES + 4000 for c in chunks)


def test_a_bag_is_never_overwritten(tmp_path):
    (tmp_path / 'x').mkdir()
    with pytest.raises(FileExistsError):
        BagWriter(tmp_path / 'x').open()
