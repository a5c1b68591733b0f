"""Fixtures of the track_msgs_py tests: a bag of ``track_msgs`` messages decoded as Foxglove would."""

from __future__ import annotations

from pathlib import Path

import pytest
from ament_index_python import get_package_share_directory
from rclpy.serialization import deserialize_message, serialize_message
from rosbags.rosbag2 import Reader, StoragePlugin, Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

SHARE = Path(get_package_share_directory('track_msgs')) / 'msg'


@pytest.fixture
def schema_bag(tmp_path):
    """``decode({topic: (msgtype, msg)})``: write an MCAP bag with the installed schemas, read it back with a
    rosbags type store that knows only the standard types and learns ours from the schemas the bag carries
    (what Foxglove or a machine without track_msgs has), check that the re-encoding of every decoded message
    is what rclpy wrote, and return {topic: decoded message}."""
    def decode(msgs: dict) -> dict:
        writer_store = get_typestore(Stores.ROS2_JAZZY)
        types: dict = {}
        for name in sorted(p.stem for p in SHARE.glob('*.msg')):
            types |= get_types_from_msg((SHARE / f'{name}.msg').read_text(), f'track_msgs/msg/{name}')
        writer_store.register(types)
        bag = tmp_path / 'schemas'
        with Writer(bag, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
            for k, (topic, (msgtype, msg)) in enumerate(sorted(msgs.items())):
                conn = writer.add_connection(topic, msgtype, typestore=writer_store)
                writer.write(conn, 1_000 + k, serialize_message(msg))
        reader_store = get_typestore(Stores.ROS2_JAZZY)  # knows nothing of track_msgs
        decoded = {}
        with Reader(bag) as reader:
            for conn in reader.connections:
                assert conn.msgdef.format.name == 'MSG' and conn.msgtype not in reader_store.fielddefs
                learnt = get_types_from_msg(conn.msgdef.data, conn.msgtype)
                reader_store.register({k: v for k, v in learnt.items() if k not in reader_store.fielddefs})
            for conn, _, raw in reader.messages():
                m = reader_store.deserialize_cdr(raw, conn.msgtype)
                sent = msgs[conn.topic][1]
                assert deserialize_message(bytes(reader_store.serialize_cdr(m, conn.msgtype)), type(sent)) == sent
                decoded[conn.topic] = m
        assert set(decoded) == set(msgs)
        return decoded
    return decode
