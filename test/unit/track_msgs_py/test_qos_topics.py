"""Topic table and QoS profiles, including compatibility with rclpy's own /clock subscription."""

import importlib

import pytest
from rclpy.parameter import Parameter
from rclpy.qos import (
    DurabilityPolicy,
    HistoryPolicy,
    QoSCompatibility,
    ReliabilityPolicy,
    qos_check_compatible,
)

from track_msgs_py.qos import CLOCK_QOS, ESTIMATE_QOS, QOS_BY_KIND, SENSOR_QOS, STATIC_QOS, qos_for_topic
from track_msgs_py.topics import CLOCK, DEMO_REPORTS, DEMO_TRACK, DEMO_TRUTH, FRAME_MAP, KNOWN_FRAMES, TOPICS


def test_demo_topic_names_and_frames():
    assert (DEMO_TRUTH, DEMO_REPORTS, DEMO_TRACK, CLOCK) == ('/demo/truth', '/demo/reports', '/demo/track', '/clock')
    assert FRAME_MAP == 'map' and FRAME_MAP in KNOWN_FRAMES


@pytest.mark.parametrize(('topic', 'msgtype', 'kind'), [
    (DEMO_TRUTH, 'nav_msgs/msg/Odometry', 'estimate'),
    (DEMO_REPORTS, 'geometry_msgs/msg/PoseWithCovarianceStamped', 'sensor'),
    (DEMO_TRACK, 'nav_msgs/msg/Odometry', 'estimate'),
    (CLOCK, 'rosgraph_msgs/msg/Clock', 'clock'),
])
def test_demo_topics_in_table(topic, msgtype, kind):
    spec = TOPICS[topic]
    assert (spec.msgtype, spec.qos) == (msgtype, kind)
    msgtype_, qos_kind, description = spec  # a plain (type, qos kind, description) tuple too
    assert description and qos_kind == kind and msgtype_ == msgtype


@pytest.mark.parametrize('topic', sorted(TOPICS))
def test_every_table_entry_is_importable_and_has_a_profile(topic):
    spec = TOPICS[topic]
    pkg, mid, name = spec.msgtype.split('/')
    assert mid == 'msg' and topic.startswith('/')
    assert hasattr(importlib.import_module(f'{pkg}.msg'), name)
    assert spec.qos in QOS_BY_KIND
    assert qos_for_topic(topic) == QOS_BY_KIND[spec.qos]


def test_profiles():
    def policy(q):
        return q.history, q.depth, q.reliability, q.durability

    assert policy(SENSOR_QOS) == (HistoryPolicy.KEEP_LAST, 5, ReliabilityPolicy.BEST_EFFORT, DurabilityPolicy.VOLATILE)
    assert policy(ESTIMATE_QOS) == (HistoryPolicy.KEEP_LAST, 10, ReliabilityPolicy.RELIABLE, DurabilityPolicy.VOLATILE)
    assert policy(STATIC_QOS) == (HistoryPolicy.KEEP_LAST, 1, ReliabilityPolicy.RELIABLE,
                                  DurabilityPolicy.TRANSIENT_LOCAL)
    assert policy(CLOCK_QOS) == (HistoryPolicy.KEEP_LAST, 1, ReliabilityPolicy.BEST_EFFORT, DurabilityPolicy.VOLATILE)


def test_qos_for_topic_defaults_to_estimate_and_returns_a_copy():
    assert qos_for_topic('/not/in/table') == ESTIMATE_QOS
    assert qos_for_topic(DEMO_REPORTS) == SENSOR_QOS
    q = qos_for_topic(DEMO_TRACK)
    q.depth = 99
    assert ESTIMATE_QOS.depth == 10


def test_same_profile_publisher_and_subscriber_are_compatible():
    # WARNING, not OK, only because liveliness is left at system default (as rclpy's own profiles do)
    for q in (SENSOR_QOS, ESTIMATE_QOS, STATIC_QOS, CLOCK_QOS):
        assert qos_check_compatible(q, q)[0] != QoSCompatibility.ERROR
    # a reliable subscriber would NOT hear a best-effort sensor publisher: the reason sensors are read best-effort
    assert qos_check_compatible(SENSOR_QOS, ESTIMATE_QOS)[0] == QoSCompatibility.ERROR


def test_clock_qos_matches_rclpy_time_source_subscription(ros):
    """A node with use_sim_time subscribes to /clock itself; our /clock publisher must match it."""
    import rclpy

    node = ros.add(rclpy.create_node('clock_qos_probe', context=ros.context,
                                     parameter_overrides=[Parameter('use_sim_time', value=True)]))
    subs = [s for s in node.subscriptions if s.topic_name == CLOCK]
    assert len(subs) == 1
    theirs = subs[0].qos_profile
    assert qos_check_compatible(CLOCK_QOS, theirs)[0] != QoSCompatibility.ERROR
    assert (theirs.reliability, theirs.durability) == (CLOCK_QOS.reliability, CLOCK_QOS.durability)
    # the check can fail: a transient-local subscriber would not match our volatile /clock publisher
    assert qos_check_compatible(CLOCK_QOS, STATIC_QOS)[0] == QoSCompatibility.ERROR
