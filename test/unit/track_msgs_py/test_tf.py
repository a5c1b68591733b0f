"""track_msgs_py.tf: names, QoS as tf2_ros's, the planar transform builder and its frame checks."""

import math

import pytest
from rclpy.qos import DurabilityPolicy, HistoryPolicy, ReliabilityPolicy

from track_msgs_py.qos import qos_for_topic
from track_msgs_py.stamps import stamp_to_sec
from track_msgs_py.tf import (
    TF,
    TF_QOS,
    TF_STATIC,
    TF_STATIC_QOS,
    frame_id_problem,
    frame_pair_problem,
    planar_transform,
    tf_message,
)
from track_msgs_py.topics import TOPICS


def test_names_and_qos_are_tf2_ros_ones():
    assert (TF, TF_STATIC) == ('/tf', '/tf_static')
    assert (TF_QOS.reliability, TF_QOS.durability, TF_QOS.history, TF_QOS.depth) == (
        ReliabilityPolicy.RELIABLE, DurabilityPolicy.VOLATILE, HistoryPolicy.KEEP_LAST, 100)
    assert (TF_STATIC_QOS.reliability, TF_STATIC_QOS.durability, TF_STATIC_QOS.history, TF_STATIC_QOS.depth) == (
        ReliabilityPolicy.RELIABLE, DurabilityPolicy.TRANSIENT_LOCAL, HistoryPolicy.KEEP_LAST, 1)
    assert TOPICS[TF].msgtype == TOPICS[TF_STATIC].msgtype == 'tf2_msgs/msg/TFMessage'
    assert qos_for_topic(TF) == TF_QOS and qos_for_topic(TF_STATIC) == TF_STATIC_QOS


def test_planar_transform_carries_the_pose():
    tr = planar_transform(12.5, 'map', 'laser', 3.0, -4.0, 2.5)
    assert (tr.header.frame_id, tr.child_frame_id, stamp_to_sec(tr.header.stamp)) == ('map', 'laser', 12.5)
    assert (tr.transform.translation.x, tr.transform.translation.y, tr.transform.translation.z) == (3.0, -4.0, 0.0)
    q = tr.transform.rotation
    assert math.isclose(2 * math.atan2(q.z, q.w), 2.5) and q.x == q.y == 0.0
    assert math.isclose(q.z**2 + q.w**2, 1.0)
    assert tf_message([tr, tr]).transforms[1].child_frame_id == 'laser'


@pytest.mark.parametrize(('parent', 'child', 'words'), [
    ('/map', 'laser', 'starts with "/"'),
    ('map', '/laser', 'starts with "/"'),
    ('map', 'map', 'equals the parent'),
    ('', 'laser', 'empty'),
    ('map', 'la ser', 'white space'),
])
def test_frame_pairs_tf2_refuses_are_refused(parent, child, words):
    assert words in frame_pair_problem(parent, child)
    with pytest.raises(ValueError, match=words.replace('"', '.')):
        planar_transform(0.0, parent, child, 0.0, 0.0, 0.0)


def test_non_finite_pose_is_refused_and_good_ids_pass():
    with pytest.raises(ValueError, match='non-finite'):
        planar_transform(0.0, 'map', 'laser', float('nan'), 0.0, 0.0)
    assert frame_id_problem('radar/t0+patrol/t0') is None
    assert frame_pair_problem('map', 'rfid_user') is None
