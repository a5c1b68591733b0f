"""Display twins (base/twins.py): a node's Odometry and PointStamped topics that the layouts draw come with a
drawable twin on ``<topic>/pose``, in any namespace; others, and a player's raw replay, do not."""

from __future__ import annotations

import numpy as np
from geometry_msgs.msg import PointStamped, PoseStamped, PoseWithCovarianceStamped
from nav_msgs.msg import Odometry
from rclpy.node import Node

from track_msgs_py.odometry import cv_state_to_odometry
from track_msgs_py.qos import ESTIMATE_QOS
from track_msgs_py.topics import DEMO_TRUTH, SONAR_ESTIMATE, SONAR_PING
from track_nodes.base import TrackNode


class Publisher(TrackNode):
    DEFAULT_NAME = 'twin_publisher'

    def setup(self) -> None:
        self.est = self.create_publisher(Odometry, SONAR_ESTIMATE, ESTIMATE_QOS)
        self.ping = self.create_publisher(PointStamped, SONAR_PING, ESTIMATE_QOS)
        self.truth = self.create_publisher(Odometry, DEMO_TRUTH, ESTIMATE_QOS)  # no layout draws it: no twin
        self.raw = self.create_publisher(Odometry, '/replayed', ESTIMATE_QOS, as_given=True)


def test_a_drawn_topic_has_its_twin_in_any_namespace(ros):
    pub = ros.add(Publisher(context=ros.context, cli_args=['--ros-args', '-r', '__ns:=/robot1']))
    sink = ros.add(Node('sink', context=ros.context))
    got: dict[str, list] = {'est': [], 'ping': []}
    sink.create_subscription(PoseWithCovarianceStamped, '/robot1/sonar/estimate/pose', got['est'].append, ESTIMATE_QOS)
    sink.create_subscription(PoseStamped, '/robot1/sonar/ping/pose', got['ping'].append, ESTIMATE_QOS)
    assert ros.spin_until(lambda: pub.est.twin.get_subscription_count() and pub.ping.twin.get_subscription_count(),
                          timeout=30)
    assert pub.est.topic_name == '/robot1/sonar/estimate'  # the wrapper is the publisher for everything else
    odom = cv_state_to_odometry(3.0, np.array([1.0, 2.0, 3.0, 4.0]), np.diag([4.0, 1.0, 9.0, 1.0]))
    pub.est.publish(odom)
    ping = PointStamped()
    ping.header.frame_id, ping.point.x = 'map', 7.0
    pub.ping.publish(ping)
    assert ros.spin_until(lambda: got['est'] and got['ping'], timeout=30)
    assert got['est'][0].pose == odom.pose and got['est'][0].header == odom.header
    assert got['ping'][0].pose.position.x == 7.0
    names = {n for n, _ in pub.get_topic_names_and_types()}
    assert '/robot1/demo/truth/pose' not in names and '/replayed/pose' not in names
    assert not hasattr(pub.truth, 'twin') and not hasattr(pub.raw, 'twin')
