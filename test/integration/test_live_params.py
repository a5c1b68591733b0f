"""Parameters at run time (issue 19, item 6), through the parameter services with an rclpy client.

A live parameter (rates, thresholds, δ, gates) is checked like a start value and applied; every
other one is read-only, so a change is refused with a reason instead of "successful" and ignored.
"""

from __future__ import annotations

import pytest
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.parameter_client import AsyncParameterClient
from rosgraph_msgs.msg import Clock

from track_msgs_py.qos import CLOCK_QOS, ESTIMATE_QOS
from track_msgs_py.stamps import sec_to_stamp, stamp_to_sec
from track_msgs_py.topics import CLOCK, DEMO_TRUTH
from track_nodes.demo.demo_target import DemoTargetNode
from track_nodes.fusion.fusion import FusionNode
from track_nodes.sonar.sonar_observer import SonarObserverNode

pytestmark = pytest.mark.integration


def _client(ros, node_name: str) -> AsyncParameterClient:
    client = AsyncParameterClient(ros.add(Node(f'param_client_for_{node_name}', context=ros.context)), node_name)
    assert ros.spin_until(client.services_are_ready, timeout=30)
    return client


def _set(ros, client, **values):
    future = client.set_parameters([Parameter(k, value=v) for k, v in values.items()])
    assert ros.spin_until(future.done, timeout=30)
    return future.result().results


def test_read_only_and_out_of_range_changes_are_refused_with_a_reason(ros):
    node = ros.add(DemoTargetNode(context=ros.context))
    client = _client(ros, 'demo_target')
    x0 = list(node.get_parameter('x0').value)
    (res,) = _set(ros, client, x0=[1.0, 2.0])
    assert not res.successful and 'read-only' in res.reason
    (res,) = _set(ros, client, period=-1.0)
    assert not res.successful and 'period' in res.reason
    assert list(node.get_parameter('x0').value) == x0 and node.p.period == node.get_parameter('period').value
    future = client.describe_parameters(['x0', 'period'])
    assert ros.spin_until(future.done, timeout=30)
    d_x0, d_period = future.result().descriptors
    assert d_x0.read_only and not d_period.read_only and 'settable at run time' in d_period.description


def test_a_new_period_changes_the_step_spacing(ros):
    node = ros.add(DemoTargetNode(context=ros.context, parameter_overrides=[
        Parameter('use_sim_time', value=True), Parameter('period', value=0.5)]))
    probe = ros.add(Node('period_probe', context=ros.context))
    stamps: list[float] = []
    probe.create_subscription(Odometry, DEMO_TRUTH, lambda m: stamps.append(stamp_to_sec(m.header.stamp)), ESTIMATE_QOS)
    clock = probe.create_publisher(Clock, CLOCK, CLOCK_QOS)
    client = _client(ros, 'demo_target')
    assert ros.spin_until(lambda: node.pub_truth.get_subscription_count() > 0, timeout=30)

    def run_to(t_end: float, dt: float = 0.05) -> None:
        t = run_to.t
        while t < t_end - 1e-9:
            t = round(t + dt, 6)
            clock.publish(Clock(clock=sec_to_stamp(t)))
            ros.spin_until(lambda t=t: node.get_clock().now().nanoseconds >= round(t * 1e9), timeout=10)
        run_to.t = t
    run_to.t = 0.0
    run_to(2.0)
    assert ros.spin_until(lambda: len(stamps) >= 4, timeout=30)
    (res,) = _set(ros, client, period=0.2)
    assert res.successful and node.p.period == 0.2
    n_before = len(stamps)
    run_to(4.0)
    assert ros.spin_until(lambda: len(stamps) >= n_before + 8, timeout=30), stamps
    gaps = {round(b - a, 6) for a, b in zip(stamps[n_before:], stamps[n_before + 1:], strict=False)}
    assert gaps == {0.2}, stamps


def test_fusion_threshold_and_sonar_delta_reach_the_core(ros):
    fusion = ros.add(FusionNode(context=ros.context, parameter_overrides=[
        Parameter('odometry_topics', value=['/a/track', '/b/track'])]))
    observer = ros.add(SonarObserverNode(context=ros.context))
    to_fusion = _client(ros, 'fusion')
    (res,) = _set(ros, to_fusion, threshold=0.8)
    assert res.successful and fusion.core.threshold == 0.8
    (res,) = _set(ros, to_fusion, threshold=1.5)
    assert not res.successful and fusion.core.threshold == 0.8
    (res,) = _set(ros, to_fusion, method='glr')
    assert not res.successful and 'read-only' in res.reason and fusion.core.method == 'exact'
    (res,) = _set(ros, _client(ros, 'sonar_observer'), delta=9.0)
    assert res.successful and observer.tracker.scheduler.delta == 9.0
