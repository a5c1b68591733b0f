"""Clock jumps reset what estimators keep in time order; bounded look-ahead; the innovation gate.

- a backwards jump of /clock (a bag restarting, a simulator reset) resets the tracker and its stamp
  watermark, with one log line, and the reports of the new run are fused;
- a report stamped 55 s ahead (inside the 60 s horizon) is refused and does not blank the track;
- a second publisher 1000 m off is refused by the innovation gate, counted on /diagnostics and
  warned about, while the honest source is still fused;
- ``track-play --loop`` of a sample bag into the demo tracker: valid tracks through three loops.
"""

from __future__ import annotations

import math
import os

import numpy as np
import pytest
import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from nav_msgs.msg import Odometry
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock

from track_core.sonar.contacts import Contact
from track_core.sonar.models import SensorMode
from track_msgs.msg import PairScoreArray
from track_msgs_py.clouds import scan_to_pointcloud2
from track_msgs_py.odometry import inputs_to_twist, position_to_pose_cov
from track_msgs_py.records import diagnostic_values
from track_msgs_py.records.sonar import contact_to_msg, fix_to_odometry
from track_msgs_py.stamps import sec_to_stamp
from track_msgs_py.topics import DEMO_REPORTS, DEMO_TRACK, DIAGNOSTICS, FRAME_MAP
from track_nodes.bag.player import PlayerNode
from track_nodes.demo.demo_tracker import DemoTrackerNode
from track_nodes.fusion.fusion import FusionNode
from track_nodes.rfid.rfid_guidance import RfidGuidanceNode
from track_nodes.slam.slam import SlamNode
from track_nodes.sonar.sonar_observer import SonarObserverNode

pytestmark = pytest.mark.integration


class Lines:
    """Stands in for ``node.get_logger()``: keeps warning lines, passes everything else on."""

    def __init__(self, node) -> None:
        self.real, self.warnings = node.get_logger(), []
        node.get_logger = lambda: self

    def warning(self, msg, **kwargs) -> None:
        self.warnings.append(msg)

    warn = warning

    def __getattr__(self, name):
        return getattr(self.real, name)


def _report(t, z=(1.0, 2.0), R=((4.0, 0.5), (0.5, 3.0))):
    return position_to_pose_cov(t, np.asarray(z, float), np.asarray(R, float), FRAME_MAP)


def _demo(ros, **params):
    node = ros.add(DemoTrackerNode(context=ros.context,
                                   parameter_overrides=[Parameter(k, value=v) for k, v in params.items()]))
    out = []
    node.pub.publish = out.append
    return node, out


def _now(node) -> float:
    return node.get_clock().now().nanoseconds * 1e-9


def _set_clock(ros, pub, node, t: float) -> None:
    pub.publish(Clock(clock=sec_to_stamp(t)))
    assert ros.spin_until(lambda: abs(_now(node) - t) < 1e-6, 30.0), _now(node)


def test_a_backwards_clock_jump_resets_the_tracker_with_one_line(ros):
    node, out = _demo(ros, use_sim_time=True)
    lines = Lines(node)
    clock = ros.add(rclpy.create_node('clock_source', context=ros.context))
    pub = clock.create_publisher(Clock, '/clock', 10)
    assert ros.spin_until(lambda: pub.get_subscription_count() > 0, 30.0)
    _set_clock(ros, pub, node, 100.0)
    for k in range(5):
        node._on_report(_report(100.0 + 0.1 * k, (1.0 + 0.1 * k, 2.0)))
    assert len(out) == 5 and not lines.warnings
    _set_clock(ros, pub, node, 10.0)  # the bag starts again
    assert len(lines.warnings) == 1, lines.warnings
    assert 'clock jumped back' in lines.warnings[0] and 'tracker' in lines.warnings[0] \
        and 'stamp watermark' in lines.warnings[0], lines.warnings
    assert not node.tracker.initialised and node.stamps.last(DEMO_REPORTS) is None
    for k in range(5):
        node._on_report(_report(10.0 + 0.1 * k, (1.0 + 0.1 * k, 2.0)))
    assert len(out) == 10 and node.rejected == 0
    assert out[-1].header.stamp.sec == 10
    _set_clock(ros, pub, node, 10.5)  # an ordinary step forward resets nothing
    assert len(lines.warnings) == 1 and node.time_jumps.jumps == 1


def test_a_forward_jump_beyond_the_horizon_resets_too(ros):
    node, _out = _demo(ros, use_sim_time=True)
    lines = Lines(node)
    clock = ros.add(rclpy.create_node('clock_source', context=ros.context))
    pub = clock.create_publisher(Clock, '/clock', 10)
    assert ros.spin_until(lambda: pub.get_subscription_count() > 0, 30.0)
    _set_clock(ros, pub, node, 100.0)
    node._on_report(_report(100.0))
    _set_clock(ros, pub, node, 1000.0)
    assert len(lines.warnings) == 1 and 'clock jumped forward' in lines.warnings[0], lines.warnings
    assert not node.tracker.initialised


def test_a_report_55_s_ahead_does_not_blank_the_track(ros):
    node, out = _demo(ros)
    t0 = _now(node)
    node._on_report(_report(t0))
    node._on_report(_report(t0 + 55.0))  # inside the 60 s horizon, beyond the look-ahead tolerance
    assert len(out) == 1 and node.rejected == 1
    assert list(node.refusals.counts) == [(DEMO_REPORTS, 'header.stamp')]
    for k in range(1, 6):
        node._on_report(_report(t0 + 0.1 * k, (1.0 + 0.1 * k, 2.0)))
    assert len(out) == 6 and node.rejected == 1


def test_a_rogue_at_100_hz_does_not_take_the_track_and_a_real_jump_is_logged_and_counted(ros):
    """Ten rogue reports 1000 m off between two honest ones (100 Hz against 10 Hz) are ten gate misses in a
    row, but the honest source keeps coming, so the track stays; when the honest source itself jumps, the
    track is re-initialised after gate_lost_time, with one line and a count."""
    node, out = _demo(ros)
    lines = Lines(node)
    t0 = _now(node) - 20.0
    for k in range(50):
        t = t0 + 0.1 * k
        node._on_report(_report(t, (1.0 + 0.05 * k, 2.0)))
        for j in range(10):
            node._on_report(_report(t + 0.005 + 0.0095 * j, (1001.0, 2.0)))
    assert len(out) == 50 and node.rejected == 500 and node.reinitialisations == 0
    assert all(abs(m.pose.pose.position.x - (1.0 + 0.05 * k)) < 20.0 for k, m in enumerate(out))
    for k in range(50, 80):  # the target really is 1000 m away now
        node._on_report(_report(t0 + 0.1 * k, (1001.0 + 0.05 * k, 2.0)))
    assert node.reinitialisations == 1
    assert abs(out[-1].pose.pose.position.x - (1001.0 + 0.05 * 79)) < 20.0
    assert sum('re-initialised' in w for w in lines.warnings) == 1, lines.warnings


def test_a_second_publisher_1000_m_off_is_gated_counted_and_warned_about(ros):
    node, out = _demo(ros)
    lines = Lines(node)
    got: list[DiagnosticArray] = []
    listener = ros.add(rclpy.create_node('listener', context=ros.context))
    listener.create_subscription(DiagnosticArray, DIAGNOSTICS, got.append, 10)
    honest = ros.add(rclpy.create_node('honest', context=ros.context)).create_publisher(
        type(_report(1.0)), DEMO_REPORTS, 10)
    rogue = ros.add(rclpy.create_node('rogue', context=ros.context)).create_publisher(
        type(_report(1.0)), DEMO_REPORTS, 10)
    assert ros.spin_until(lambda: honest.get_subscription_count() > 0 and rogue.get_subscription_count() > 0, 30.0)
    t0 = _now(node)
    n = 40
    for k in range(n):  # one at a time: the subscription keeps a few messages only
        t = t0 - 10.0 + 0.1 * k
        honest.publish(_report(t, (1.0 + 0.05 * k, 2.0)))
        assert ros.spin_until(lambda k=k: len(out) + node.rejected >= 2 * k + 1, 30.0)
        rogue.publish(_report(t + 0.05, (1001.0 + 0.05 * k, 2.0)))
        assert ros.spin_until(lambda k=k: len(out) + node.rejected >= 2 * k + 2, 30.0)
    assert len(out) == n and node.rejected == n  # every honest report fused, every rogue one refused
    gated = sum(c for (_, kind), c in node.refusals.counts.items() if kind == 'innovation gate')
    assert gated == n
    assert all(abs(m.pose.pose.position.x - (1.0 + 0.05 * k)) < 20.0 for k, m in enumerate(out)), \
        'the honest source is fused, the rogue is not'
    assert any('a second publisher' in w for w in lines.warnings), lines.warnings

    def counted() -> str | None:
        values = diagnostic_values(got[-1].status[0]) if got else {}
        return values.get(f'{DEMO_REPORTS} innovation gate')

    assert ros.spin_until(lambda: counted() == str(n), 30.0), counted()


def _valid(msg: Odometry) -> bool:
    p = msg.pose.pose.position
    return all(math.isfinite(c) for c in (p.x, p.y, *msg.pose.covariance)) and abs(p.x) < 1e4 and abs(p.y) < 1e4


def _stamp(msg) -> float:
    return msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9


def test_track_play_loop_keeps_the_demo_tracker_producing_through_three_loops(ros, repo):
    track_id = f'loop_test_{os.getpid()}'  # only this tracker's tracks count
    ros.add(DemoTrackerNode(context=ros.context, parameter_overrides=[Parameter('use_sim_time', value=True),
                                                                      Parameter('track_id', value=track_id)]))
    loops: list[list[Odometry]] = [[]]  # the tracks of each pass of the bag (a new pass: the stamps go back)

    def on_track(m: Odometry) -> None:
        if m.child_frame_id != track_id:
            return
        if loops[-1] and _stamp(m) < _stamp(loops[-1][-1]):
            loops.append([])
        loops[-1].append(m)

    sink = ros.add(rclpy.create_node('sink', context=ros.context))
    sink.create_subscription(Odometry, DEMO_TRACK, on_track, 100)
    ros.add(PlayerNode(context=ros.context, parameter_overrides=[
        Parameter('bag', value=str(repo / 'bags/sample-demo')), Parameter('rate', value=5.0),
        Parameter('loop', value=True), Parameter('topics', value=[DEMO_REPORTS])]))
    assert ros.spin_until(lambda: len(loops) >= 4 and len(loops[3]) >= 20, 120.0), [len(x) for x in loops]
    assert all(len(x) >= 20 for x in loops[:4]), [len(x) for x in loops]
    assert all(_valid(m) for x in loops for m in x)


# --- every estimator that keeps time state: one line and a fresh start after /clock goes back -------------

def _feed_fusion(node, t: float) -> None:
    node._on_pose(node.resolve_topic_name('/radar/t0'), _report(t))


def _feed_slam(node, t: float) -> None:
    trees = np.array([[10.0, 1.0], [12.0, 2.0], [15.0, 1.5]])
    node._on_scan(scan_to_pointcloud2(t, trees, np.full(len(trees), 0.3)))
    node._on_input(inputs_to_twist(t + 0.05, 1.0, 0.0))


def _feed_sonar(node, t: float) -> None:
    node._on_nav(fix_to_odometry(round(t * 1e9), np.zeros(2), np.array([1.0, 0.0]), FRAME_MAP, 'sonar_observer'))
    contact = Contact(round(t * 1e9), SensorMode.PASSIVE, 0.7, math.nan, np.array([[1e-4]]))
    node._on_contact(contact_to_msg(contact, FRAME_MAP))


def _make(ros, repo, name: str):
    sim = [Parameter('use_sim_time', value=True)]
    if name == 'fusion':
        return FusionNode(context=ros.context,
                          parameter_overrides=[*sim, Parameter('pose_topics', value=['/radar/t0'])])
    if name == 'slam':
        return SlamNode(context=ros.context, parameter_overrides=sim)
    if name == 'sonar_observer':
        return SonarObserverNode(node_name=name, context=ros.context, parameter_overrides=sim,
                                 cli_args=['--ros-args', '--params-file', str(repo / 'config/sonar.yaml')])
    return RfidGuidanceNode(context=ros.context, parameter_overrides=sim)


FEED = {'fusion': _feed_fusion, 'slam': _feed_slam, 'sonar_observer': _feed_sonar, 'rfid_guidance': None}


@pytest.mark.parametrize('name', list(FEED))
def test_every_estimator_starts_again_after_the_clock_goes_back(ros, repo, name):
    node = ros.add(_make(ros, repo, name))
    lines = Lines(node)
    clock = ros.add(rclpy.create_node('clock_source', context=ros.context))
    pub = clock.create_publisher(Clock, '/clock', 10)
    assert ros.spin_until(lambda: pub.get_subscription_count() > 0, 30.0)
    feed = FEED[name]
    _set_clock(ros, pub, node, 100.0)
    if feed is not None:
        feed(node, 100.0)
    refused = node.refusals.total()
    _set_clock(ros, pub, node, 10.0)
    jumps = [w for w in lines.warnings if 'clock jumped back' in w]
    assert len(jumps) == 1 and 'reset' in jumps[0], lines.warnings
    if feed is not None:  # the new run is taken, not refused as "time went backwards"
        feed(node, 10.0)
        assert node.refusals.total() == refused, node.refusals.counts
    else:
        assert node.loop.cmd is None


# --- track-play --loop of each scenario's sample bag into its estimator ----------------------------------

LOOPS = {  # scenario: (estimator class, its section in config/<scenario>.yaml, topics played, output, type)
    'fusion': (FusionNode, 'fusion', ['/radar/t0', '/radar/t1', '/radar/t2', '/patrol/t0', '/patrol/t1'],
               '/fusion/scores', PairScoreArray),
    'sonar': (SonarObserverNode, 'sonar_observer', ['/sonar/contacts', '/sonar/observer/odom'], '/sonar/estimate',
              Odometry),
    'slam_sim': (SlamNode, 'slam', ['/slam/inputs', '/slam/scan'], '/slam/pose', Odometry),
}


def _finite(msg) -> bool:
    if isinstance(msg, Odometry):
        return _valid(msg)
    return all(math.isfinite(q.score) and math.isfinite(q.combined) for q in msg.pairs)


@pytest.mark.parametrize('scenario', list(LOOPS))
def test_track_play_loop_keeps_each_estimator_producing_through_three_loops(ros, repo, scenario):
    cls, name, topics, output, msg_type = LOOPS[scenario]
    ros.add(cls(node_name=name, context=ros.context, parameter_overrides=[Parameter('use_sim_time', value=True)],
                cli_args=['--ros-args', '--params-file', str(repo / f'config/{scenario}.yaml')]))
    loops: list[list] = [[]]

    def on_output(m) -> None:
        if loops[-1] and _stamp(m) < _stamp(loops[-1][-1]):
            loops.append([])
        loops[-1].append(m)

    sink = ros.add(rclpy.create_node('sink', context=ros.context))
    sink.create_subscription(msg_type, output, on_output, 100)
    bag = repo / f'bags/sample-{scenario.removesuffix("_sim")}'
    ros.add(PlayerNode(context=ros.context, parameter_overrides=[
        Parameter('bag', value=str(bag)), Parameter('rate', value=5.0), Parameter('loop', value=True),
        Parameter('topics', value=topics)]))
    want = 3
    assert ros.spin_until(lambda: len(loops) >= 4 and len(loops[3]) >= want, 120.0), [len(x) for x in loops]
    assert all(len(x) >= want for x in loops[:4]), [len(x) for x in loops]
    assert all(_finite(m) for x in loops for m in x)
