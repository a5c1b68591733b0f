"""Namespaces and remapping: two namespaced demo scenarios side by side, no crosstalk.

Each instance is the demo scenario's pair (demo_target → demo_tracker) started with
``-r __ns:=/robotN``, on wall time, in one process. Their topics resolve under their namespace, each
tracker follows its own target only (the targets are 10 km apart), nothing is published in the root
namespace, and a refused message is counted and logged under the resolved topic name.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from geometry_msgs.msg import PoseWithCovarianceStamped
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.parameter import Parameter

from track_msgs_py.qos import ESTIMATE_QOS
from track_msgs_py.topics import DEMO_REPORTS, DEMO_TRACK, DEMO_TRUTH
from track_nodes.base import ParameterError
from track_nodes.demo.demo_target import DemoTargetNode
from track_nodes.demo.demo_tracker import DemoTrackerNode

pytestmark = pytest.mark.integration

X0 = {'/robot1': [0.0, 5.0, 0.0, 2.0], '/robot2': [10_000.0, -3.0, 10_000.0, 1.0]}


def _instance(ros, repo, ns: str):
    cli = ['--ros-args', '--params-file', str(repo / 'config/demo.yaml'), '-r', f'__ns:={ns}']
    target = ros.add(DemoTargetNode(context=ros.context, cli_args=cli,
                                    parameter_overrides=[Parameter('x0', value=X0[ns])]))
    tracker = ros.add(DemoTrackerNode(context=ros.context, cli_args=cli))
    return target, tracker


def test_two_namespaced_instances_run_side_by_side(ros, repo):
    nodes = {ns: _instance(ros, repo, ns) for ns in X0}
    probe = ros.add(Node('ns_probe', context=ros.context))
    got: dict[str, list] = {}
    for ns in X0:
        for topic in (DEMO_TRACK, DEMO_TRUTH):
            name = ns + topic
            got[name] = []
            probe.create_subscription(Odometry, name, got[name].append, ESTIMATE_QOS)
    target, tracker = nodes['/robot1']
    assert target.pub_report.topic_name == '/robot1' + DEMO_REPORTS
    assert tracker.get_fully_qualified_name() == '/robot1/demo_tracker'
    assert ros.spin_until(lambda: all(len(v) >= 20 for v in got.values()), timeout=60), \
        {k: len(v) for k, v in got.items()}
    for ns in X0:
        track, truth = got[ns + DEMO_TRACK][-1], got[ns + DEMO_TRUTH][-1]
        d = math.hypot(track.pose.pose.position.x - truth.pose.pose.position.x,
                       track.pose.pose.position.y - truth.pose.pose.position.y)
        assert d < 50.0, (ns, d)  # its own target (the other one is 10 km away)
    root = {name for name, _ in probe.get_topic_names_and_types() if name.startswith('/demo/')}
    assert root == set(), root


def test_a_refusal_names_the_resolved_topic(ros, repo):
    _, tracker = _instance(ros, repo, '/robot1')
    probe = ros.add(Node('ns_bad_probe', context=ros.context))
    pub = probe.create_publisher(PoseWithCovarianceStamped, '/robot1' + DEMO_REPORTS, 10)
    assert ros.spin_until(lambda: pub.get_subscription_count() > 0, timeout=30)
    bad = PoseWithCovarianceStamped()
    bad.header.frame_id = 'map'
    bad.header.stamp.sec = 1
    bad.pose.pose.position.x = float('nan')
    bad.pose.covariance = list(np.eye(6).ravel())
    pub.publish(bad)
    assert ros.spin_until(lambda: tracker.refusals.total() > 0, timeout=30)
    assert all(key.startswith('/robot1' + DEMO_REPORTS + ' ') for key in tracker.refusals.by_key())


def test_scenario_files_apply_in_a_namespace(ros, repo, tmp_path):
    """config/*.yaml name their sections ``/**/node``, so ``-r __ns:=/robot1`` keeps the scenario's
    parameters, and a typo under such a section is still refused for that node."""
    target, _ = _instance(ros, repo, '/robot1')
    assert target.get_parameter('seed').value == 7  # the node's default is 0
    bad = tmp_path / 'typo.yaml'
    bad.write_text((repo / 'config/demo.yaml').read_text().replace('    seed: 7\n', '    sead: 7\n'))
    with pytest.raises(ParameterError, match=r"'sead' \(did you mean seed\?\).*for node /robot2/demo_target"):
        DemoTargetNode(context=ros.context, cli_args=['--ros-args', '--params-file', str(bad), '-r', '__ns:=/robot2'])
