"""The recorder records /tf and /tf_static whatever the filter (a late recorder still gets the statics),
unless told not to (tf false, --no-tf)."""

from __future__ import annotations

import pytest
import rclpy
from nav_msgs.msg import Odometry
from rclpy.parameter import Parameter
from rclpy.serialization import deserialize_message
from rosbags.interfaces import QosDurability
from rosbags.rosbag2 import Reader
from tf2_msgs.msg import TFMessage

from track_msgs_py.tf import TF, TF_QOS, TF_STATIC, TF_STATIC_QOS, planar_transform, tf_message
from track_nodes.bag.recorder import RecorderNode, parse_cli

pytestmark = pytest.mark.integration


def _recorder(ros, bag, **params) -> RecorderNode:
    overrides = [Parameter('bag', value=str(bag)), Parameter('flush_period', value=0.2)]
    overrides += [Parameter(k, value=v) for k, v in params.items()]
    return ros.add(RecorderNode(context=ros.context, parameter_overrides=overrides))


def _close(ros, node) -> None:
    ros.executor.remove_node(node)
    ros.nodes.remove(node)
    node.destroy_node()


def _bag(bag):
    with Reader(bag) as reader:
        conns = {c.topic: c for c in reader.connections}
        msgs: dict[str, list[bytes]] = {}
        for conn, _, raw in reader.messages():
            msgs.setdefault(conn.topic, []).append(bytes(raw))
    return conns, msgs


@pytest.mark.parametrize('tf', [True, False])
def test_tf_topics_are_recorded_with_a_regex_unless_excluded(ros, tmp_path, tf):
    node = ros.add(rclpy.create_node('tf_pub', context=ros.context))
    pub_static = node.create_publisher(TFMessage, TF_STATIC, TF_STATIC_QOS)
    pub_static.publish(tf_message([planar_transform(0.0, 'map', 'gps', 1.0, 2.0, 0.0),
                                   planar_transform(0.0, 'map', 'dock', 3.0, 0.0, 0.0)]))  # before the recorder
    pub_tf = node.create_publisher(TFMessage, TF, TF_QOS)
    pub_odom = node.create_publisher(Odometry, '/x/odom', 10)
    rec = _recorder(ros, tmp_path / 'tfbag', regex='^/x/', tf=tf)
    want_subs = {'/x/odom', TF, TF_STATIC} if tf else {'/x/odom'}
    assert ros.spin_until(lambda: set(rec.subscriptions_by_topic) == want_subs, 20.0), rec.subscriptions_by_topic
    if tf:
        assert ros.spin_until(lambda: pub_tf.get_subscription_count() > 0, 10.0)
    assert ros.spin_until(lambda: pub_odom.get_subscription_count() > 0, 10.0)
    ros.spin_for(0.2)
    for k in range(3):
        pub_tf.publish(tf_message([planar_transform(float(k), 'map', 'laser', float(k), 0.0, 0.0)]))
        pub_odom.publish(Odometry())
    want = {'/x/odom': 3, TF: 3, TF_STATIC: 1} if tf else {'/x/odom': 3}
    assert ros.spin_until(lambda: rec.message_counts() == want, 10.0), rec.message_counts()
    ros.spin_for(0.3)
    assert rec.message_counts() == want
    _close(ros, rec)
    conns, msgs = _bag(tmp_path / 'tfbag')
    assert set(conns) == set(want)
    if tf:
        static = deserialize_message(msgs[TF_STATIC][0], TFMessage)  # the late recorder got the latched one
        assert [t.child_frame_id for t in static.transforms] == ['gps', 'dock']
        assert conns[TF_STATIC].ext.offered_qos_profiles[0].durability == QosDurability.TRANSIENT_LOCAL
        assert conns[TF].msgtype == 'tf2_msgs/msg/TFMessage'


def test_cli_no_tf_sets_the_parameter():
    assert [(p.name, p.value) for p in parse_cli(['track-record', 'b', '-e', '^/x/', '--no-tf'])] == [
        ('bag', 'b'), ('regex', '^/x/'), ('tf', False)]
    assert all(p.name != 'tf' for p in parse_cli(['track-record', 'b']))
