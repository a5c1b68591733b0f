"""TrackNode.send_transforms / add_static_transforms: lazy publishers, one latched static message."""

from __future__ import annotations

import pytest
import rclpy
from tf2_msgs.msg import TFMessage

from track_msgs_py.tf import TF, TF_QOS, TF_STATIC, TF_STATIC_QOS, planar_transform
from track_nodes.base import TrackNode

pytestmark = pytest.mark.integration


class _Broadcaster(TrackNode):
    DEFAULT_NAME = 'broadcaster'


def test_no_tf_endpoint_until_the_first_transform(ros):
    node = ros.add(_Broadcaster(context=ros.context))
    names = {n for n, _ in node.get_publisher_names_and_types_by_node(node.get_name(), node.get_namespace())}
    assert TF not in names and TF_STATIC not in names
    node.advertise_transforms()  # a node that will broadcast: /tf exists before the first transform
    names = {n for n, _ in node.get_publisher_names_and_types_by_node(node.get_name(), node.get_namespace())}
    assert TF in names and TF_STATIC not in names


def test_dynamic_and_static_transforms_reach_a_late_subscriber(ros):
    node = ros.add(_Broadcaster(context=ros.context))
    node.add_static_transforms(planar_transform(0.0, 'map', 'a', 1.0, 0.0, 0.0))
    node.add_static_transforms(planar_transform(0.0, 'a', 'b', 2.0, 0.0, 0.0),
                               planar_transform(0.0, 'map', 'a', 5.0, 0.0, 0.0))  # replaces map -> a
    listener = ros.add(rclpy.create_node('listener', context=ros.context))  # joins after the static sends
    static: list[TFMessage] = []
    dynamic: list[TFMessage] = []
    listener.create_subscription(TFMessage, TF_STATIC, static.append, TF_STATIC_QOS)
    listener.create_subscription(TFMessage, TF, dynamic.append, TF_QOS)
    assert ros.spin_until(lambda: bool(static), 30.0)
    assert len(static) == 1  # depth 1: the last message, which carries ALL static transforms
    got = {(t.header.frame_id, t.child_frame_id): t.transform.translation.x for t in static[0].transforms}
    assert got == {('map', 'a'): 5.0, ('a', 'b'): 2.0}
    node.send_transforms(planar_transform(1.0, 'map', 'c', 0.0, 0.0, 0.0))
    assert ros.spin_until(lambda: node.count_subscribers(TF) > 0, 30.0)
    node.send_transforms(planar_transform(2.0, 'map', 'c', 1.0, 0.0, 0.0), planar_transform(2.0, 'c', 'd', 0, 0, 0))
    assert ros.spin_until(lambda: any(len(m.transforms) == 2 for m in dynamic), 30.0)
    assert [t.child_frame_id for t in dynamic[-1].transforms] == ['c', 'd']


def test_static_transforms_are_stamped_now_and_wait_for_the_first_clock(ros):
    """Under use_sim_time before /clock there is no time yet: /tf_static waits for it, never stamped 0."""
    from rclpy.parameter import Parameter
    from rosgraph_msgs.msg import Clock

    from track_msgs_py.qos import CLOCK_QOS
    from track_msgs_py.stamps import ns_to_stamp, stamp_to_ns
    from track_msgs_py.topics import CLOCK

    node = ros.add(_Broadcaster(context=ros.context, parameter_overrides=[Parameter('use_sim_time', value=True)]))
    listener = ros.add(rclpy.create_node('listener', context=ros.context))
    static: list[TFMessage] = []
    listener.create_subscription(TFMessage, TF_STATIC, static.append, TF_STATIC_QOS)
    clock = listener.create_publisher(Clock, CLOCK, CLOCK_QOS)
    node.add_static_transforms(planar_transform(0.0, 'map', 'a', 1.0, 0.0, 0.0))
    assert ros.spin_until(lambda: node.count_publishers(TF_STATIC) > 0 and listener.count_publishers(TF_STATIC) > 0)
    ros.spin_for(1.0)
    assert static == []                                  # no clock yet: nothing stamped 0 was sent
    epoch_ns = 1_796_472_000_000_000_000
    assert ros.spin_until(lambda: clock.publish(Clock(clock=ns_to_stamp(epoch_ns))) or bool(static), 30.0)
    assert [stamp_to_ns(t.header.stamp) for t in static[0].transforms] == [epoch_ns]
    assert len(static) == 1


def test_static_transforms_on_wall_time_are_stamped_now(ros):
    import time

    node = ros.add(_Broadcaster(context=ros.context))
    listener = ros.add(rclpy.create_node('listener', context=ros.context))
    static: list[TFMessage] = []
    listener.create_subscription(TFMessage, TF_STATIC, static.append, TF_STATIC_QOS)
    before = time.time_ns()
    node.add_static_transforms(planar_transform(0.0, 'map', 'a', 1.0, 0.0, 0.0))
    assert ros.spin_until(lambda: bool(static), 30.0)
    from track_msgs_py.stamps import stamp_to_ns

    assert before <= stamp_to_ns(static[0].transforms[0].header.stamp) <= time.time_ns()
