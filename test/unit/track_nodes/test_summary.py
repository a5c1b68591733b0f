"""summarize(): topic families that differ only in their numbers fold into one line."""

from rclpy.serialization import serialize_message
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore
from std_msgs.msg import String

from track_nodes.report.summary import FOLD_AT, summarize


def _bag(path, topics):
    ts = get_typestore(Stores.ROS2_JAZZY)
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        for i, topic in enumerate(topics):
            conn = w.add_connection(topic, 'std_msgs/msg/String', typestore=ts)
            w.write(conn, 1_000 + i, serialize_message(String(data=topic)))


def test_numbered_families_fold_from_fold_at(tmp_path):
    many = [f'/net/sensor_{k}/handoff' for k in range(FOLD_AT)]
    few = [f'/net/node_{k}/status' for k in range(FOLD_AT - 1)]
    _bag(tmp_path / 'b', [*many, *few, '/net/estimate'])
    lines = summarize(tmp_path / 'b')
    folded = [ln for ln in lines if '/net/sensor_*/handoff' in ln]
    assert len(folded) == 1 and f'({FOLD_AT} topics)' in folded[0] and folded[0].split()[-1] == str(FOLD_AT)
    assert not any('/net/sensor_0/handoff' in ln for ln in lines)
    assert sum('/net/node_' in ln for ln in lines) == FOLD_AT - 1          # a smaller family stays listed
    assert any('/net/estimate' in ln for ln in lines)
