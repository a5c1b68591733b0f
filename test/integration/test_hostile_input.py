"""Hostile input refused by ``demo_tracker``, ``fusion``, ``slam``, ``sonar_observer``,
``smart_target`` and ``ais_nmea_source`` (its NMEA lines over UDP) without changing their state, and
without one log line per bad message.

The callbacks are called directly (deterministic; the subscription path is the one the scenario
tests exercise). After every refused message the node's core state is compared bit for bit with
its state before (``frozen``), and valid input afterwards must still give valid, finite output.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import fields, is_dataclass

import numpy as np
import pytest
from rclpy.parameter import Parameter
from sensor_msgs.msg import NavSatFix

from track_core.sonar.contacts import Contact
from track_core.sonar.models import SensorMode
from track_msgs_py.ais import datum_to_navsatfix
from track_msgs_py.clouds import scan_to_pointcloud2
from track_msgs_py.odometry import cv_state_to_odometry, inputs_to_twist, odometry_to_pose, position_to_pose_cov
from track_msgs_py.records.sonar import contact_to_msg
from track_msgs_py.stamps import sec_to_stamp
from track_msgs_py.topics import FRAME_MAP, track_frame_id
from track_msgs_py.track_arrays import tracks_to_array
from track_nodes.demo.demo_tracker import DemoTrackerNode
from track_nodes.fusion.fusion import FusionNode
from track_nodes.slam.slam import SlamNode
from track_nodes.sonar.smart_target import SmartTargetNode
from track_nodes.sonar.sonar_observer import SonarObserverNode

FAR_FUTURE = 2147483647.0  # the sec = INT32_MAX
HOSTILE_VARIANCES = (0.0, 5e-324, 1e30, 1e308)


def frozen(obj, depth: int = 0):  # noqa: PLR0911 (one return per kind of value)
    """A bit-exact, comparable image of ``obj``'s state (arrays and floats by their bytes)."""
    if depth > 12:
        return '...'
    if isinstance(obj, np.ndarray):
        return ('nd', obj.dtype.str, obj.shape, obj.tobytes())
    if isinstance(obj, (float, np.floating)):
        return ('f', np.float64(obj).tobytes())
    if obj is None or isinstance(obj, (bool, int, str, bytes, np.integer, np.bool_)):
        return obj
    if isinstance(obj, type):
        return repr(obj)
    if isinstance(obj, np.random.Generator):
        return repr(obj.bit_generator.state)
    if isinstance(obj, dict):
        return tuple((repr(k), frozen(v, depth + 1)) for k, v in obj.items())
    if isinstance(obj, (list, tuple, deque)):
        return tuple(frozen(v, depth + 1) for v in obj)
    if isinstance(obj, (set, frozenset)):
        return tuple(sorted(repr(v) for v in obj))
    if callable(obj) and not hasattr(obj, '__dict__'):
        return repr(type(obj))
    if is_dataclass(obj):
        return (type(obj).__name__, tuple((f.name, frozen(getattr(obj, f.name), depth + 1)) for f in fields(obj)))
    if hasattr(obj, '__dict__'):
        return (type(obj).__name__, frozen(vars(obj), depth + 1))
    return repr(obj)


class Lines:
    """Stands in for ``node.get_logger()``: counts warning lines, passes everything else on."""

    def __init__(self, node) -> None:
        self.real, self.warnings = node.get_logger(), []
        node.get_logger = lambda: self

    def warning(self, msg, **kwargs) -> None:
        self.warnings.append(msg)

    warn = warning

    def __getattr__(self, name):
        return getattr(self.real, name)


def _now(node) -> float:
    return node.get_clock().now().nanoseconds * 1e-9


def _report(t, z=(1.0, 2.0), R=((4.0, 0.5), (0.5, 3.0)), frame=FRAME_MAP):
    return position_to_pose_cov(t, np.asarray(z, float), np.asarray(R, float), frame)


def _hostile_reports(t: float) -> list:
    """Reports a finite-only check lets through: huge/beyond-bound positions, degenerate or huge variances."""
    bad = [_report(t, (1e308, 2.0)), _report(t, (1.0, -1e8)), _report(t, (1e30, 1e30))]
    bad += [_report(t, R=np.diag([v, v])) for v in HOSTILE_VARIANCES]
    bad += [_report(t, R=np.diag([1.0, v])) for v in HOSTILE_VARIANCES]
    return bad


# --- demo_tracker ---------------------------------------------------------------------------------------

def _demo(ros, name=None, **params):
    node = ros.add(DemoTrackerNode(node_name=name, context=ros.context,
                                   parameter_overrides=[Parameter(k, value=v) for k, v in params.items()]))
    out = []
    node.pub.publish = out.append
    return node, out


def _demo_state(node):
    return frozen((node.tracker, node.stamps))


def _finite_track(msg) -> bool:
    p, v = msg.pose.pose.position, msg.twist.twist.linear
    return all(math.isfinite(c) for c in (p.x, p.y, v.x, v.y, *msg.pose.covariance, *msg.twist.covariance))


def test_demo_far_future_and_zero_stamps_are_refused_and_the_stream_goes_on(ros):
    """Defect 1: one report stamped INT32_MAX s was accepted and every real one after it refused."""
    node, out = _demo(ros)
    t0 = _now(node)
    node._on_report(_report(t0))
    assert len(out) == 1
    before = _demo_state(node)
    for bad in (_report(FAR_FUTURE), _report(t0 + 3600.0), _report(0.0), _report(t0 + 1e8)):
        node._on_report(bad)
        assert _demo_state(node) == before
    assert len(out) == 1 and node.rejected == 4
    node._on_report(_report(t0 + 0.1, (1.1, 2.1)))  # the stream is not locked
    assert len(out) == 2 and _finite_track(out[-1]) and node.stamps.last('/demo/reports') == t0 + 0.1
    assert sum(n for (_, kind), n in node.refusals.counts.items() if kind == 'header.stamp') == 4


def test_demo_zero_stamp_refused_on_a_fresh_node(ros):
    node, out = _demo(ros)
    node._on_report(_report(0.0))
    assert not out and not node.tracker.initialised and node.stamps.last('/demo/reports') is None


def test_demo_horizon_is_a_parameter_and_skipped_while_the_sim_clock_reads_zero(ros):
    node, out = _demo(ros, stamp_horizon=1.0)
    t0 = _now(node)
    node._on_report(_report(t0 + 30.0))  # 30 s ahead, horizon 1 s
    assert not out and node.rejected == 1
    # use_sim_time and no /clock yet: the clock reads 0 and must not refuse every real stamp
    sim, sim_out = _demo(ros, 'demo_tracker_sim', use_sim_time=True)  # one node per name in a process
    assert sim.get_clock().now().nanoseconds == 0
    sim._on_report(_report(1e9))
    sim._on_report(_report(1e9 + 0.1))
    assert len(sim_out) == 2 and sim.rejected == 0


def test_demo_huge_values_and_degenerate_covariances_leave_the_track_untouched(ros):
    """Defect 2: x = 1e308 or a 1e30/5e-324 variance passed the finite checks and poisoned the track."""
    node, out = _demo(ros)
    t0 = _now(node)
    node._on_report(_report(t0))
    before = _demo_state(node)
    hostile = _hostile_reports(t0 + 0.05)
    for bad in hostile:
        node._on_report(bad)
        assert _demo_state(node) == before, bad
    assert len(out) == 1 and node.rejected == len(hostile)
    for k in range(1, 6):
        node._on_report(_report(t0 + 0.1 * k, (1.0 + 0.1 * k, 2.0)))
    assert len(out) == 6 and all(_finite_track(m) for m in out)
    assert abs(out[-1].pose.pose.position.x - 1.5) < 1.0 and abs(out[-1].pose.pose.position.y - 2.0) < 1.0


def test_demo_a_flood_of_bad_reports_costs_a_few_log_lines(ros):
    """Defect 9: demo_tracker logged one line per dropped report."""
    node, out = _demo(ros)
    lines = Lines(node)
    t0 = _now(node)
    for k in range(300):
        node._on_report(_report(t0, (math.nan, 1.0)) if k % 2 else _report(t0, R=np.diag([-5.0, 1.0])))
    assert len(lines.warnings) <= 2, lines.warnings[:5]
    assert node.rejected == 300 and node.refusals.total() == 300
    node._on_report(_report(t0))
    assert len(out) == 1


# --- fusion ---------------------------------------------------------------------------------------------

POSE_TOPICS = ['/radar/t0', '/patrol/t0']


def _fusion(ros, **params):
    over = {'pose_topics': POSE_TOPICS, 'odometry_topics': ['/odo'], 'pose_track_topics': ['/ais/reports'],
            'track_array_topics': ['/arrays'], 'navsatfix_topics': ['/gps/fix'],
            'stale_after': 1e5, 'max_prediction': 1e5, **params}
    node = ros.add(FusionNode(context=ros.context,
                              parameter_overrides=[Parameter(k, value=v) for k, v in over.items()]))
    scores = []
    node.pub_scores.publish = scores.append
    node.map_datum._on_datum(datum_to_navsatfix(1.0, 50.8, -1.2))   # the run's datum, as if latched
    return node, scores


def _fusion_state(node):
    return frozen((node.core, node.stamps))


def _odometry(t, x=(1.0, 0.5, 2.0, -0.5)):
    return cv_state_to_odometry(t, np.asarray(x, float), np.diag([4.0, 1.0, 3.0, 1.0]), FRAME_MAP, 'ship1')


def _ais(t, z=(1.0, 2.0), R=((4.0, 0.5), (0.5, 3.0))):
    return _report(t, z, R, track_frame_id(FRAME_MAP, 'r017'))


def _array(t, x=(1.0, 0.5, 2.0, -0.5), P=None):
    P = np.diag([4.0, 1.0, 3.0, 1.0]) if P is None else P
    return tracks_to_array(t, ['s1'], ['radar'], np.asarray(x, float)[None], np.asarray(P, float)[None])


def _fix(t, lat=50.81, lon=-1.19, cov=((4.0, 0.5), (0.5, 3.0)), kind=NavSatFix.COVARIANCE_TYPE_KNOWN):
    msg = NavSatFix(latitude=float(lat), longitude=float(lon), position_covariance_type=kind)
    msg.header.stamp, msg.header.frame_id = sec_to_stamp(t), 'gps'
    msg.status.status = 0     # STATUS_FIX (the message's default is STATUS_UNKNOWN)
    c = np.eye(3)
    c[:2, :2] = cov
    msg.position_covariance = c.ravel().tolist()
    return msg


PATHS = {  # fusion input path → (callback, valid message at t, track id)
    'track_array': (lambda n, m: n._on_track_array('/arrays', m), _array, '/arrays/s1'),
    'pose': (lambda n, m: n._on_pose('/radar/t0', m), _report, '/radar/t0'),
    'odometry': (lambda n, m: n._on_odometry('/odo', m), _odometry, '/odo/ship1'),
    'pose_track': (lambda n, m: n._on_pose_track('/ais/reports', m), _ais, '/ais/reports/r017'),
    'navsatfix': (lambda n, m: n._on_navsatfix('/gps/fix', m), _fix, '/gps/fix'),
}


@pytest.mark.parametrize('path', sorted(PATHS))
def test_fusion_far_future_and_zero_stamps_are_refused_on_every_input_path(ros, path):
    """Defect 1 (fusion, maritime and ais scenarios): a future stamp locked the track's stream."""
    on, make, track_id = PATHS[path]
    node, _ = _fusion(ros)
    t0 = _now(node)
    on(node, make(t0))
    before = _fusion_state(node)
    for t in (FAR_FUTURE, t0 + 3600.0, 0.0):
        on(node, make(t))
        assert _fusion_state(node) == before
    assert sum(node.dropped.values()) == 3
    on(node, make(t0 + 0.1))
    assert node.stamps.last(track_id) == t0 + 0.1 and sum(node.dropped.values()) == 3


@pytest.mark.parametrize('path', sorted(PATHS))
def test_fusion_hostile_magnitudes_and_variances_are_refused_on_every_input_path(ros, path):
    on, make, _ = PATHS[path]
    node, _ = _fusion(ros)
    t0 = _now(node)
    on(node, make(t0))
    before = _fusion_state(node)
    if path == 'odometry':
        hostile = [_odometry(t0 + 0.05, (1e308, 0.0, 1.0, 0.0)), _odometry(t0 + 0.05, (1.0, 1e30, 1.0, 0.0))]
        for v in HOSTILE_VARIANCES:
            hostile.append(cv_state_to_odometry(t0 + 0.05, np.ones(4), np.diag([v, 1.0, v, 1.0]), FRAME_MAP, 'ship1'))
    elif path == 'track_array':
        hostile = [_array(t0 + 0.05, (1e308, 0.0, 1.0, 0.0)), _array(t0 + 0.05, (1.0, 1e30, 1.0, 0.0)),
                   _array(t0 + 0.05, (np.nan, 0.0, 1.0, 0.0))]
        hostile += [_array(t0 + 0.05, P=np.diag([v, 1.0, v, 1.0])) for v in HOSTILE_VARIANCES]
        wrong_frame = _array(t0 + 0.05)
        wrong_frame.header.frame_id = 'odom'
        hostile.append(wrong_frame)
    elif path == 'navsatfix':   # NaN, huge or unprojectable lat/lon; degenerate, huge or no covariance
        t = t0 + 0.05
        hostile = [_fix(t, lat=np.nan), _fix(t, lon=1e308), _fix(t, lat=-1e30), _fix(t, lat=0.0, lon=88.8),
                   _fix(t, kind=NavSatFix.COVARIANCE_TYPE_UNKNOWN), _fix(t, cov=((np.nan, 0.0), (0.0, 1.0)))]
        hostile += [_fix(t, cov=np.diag([v, v])) for v in HOSTILE_VARIANCES]
    else:
        hostile = _hostile_reports(t0 + 0.05)
        for m in hostile if path == 'pose_track' else ():
            m.header.frame_id = track_frame_id(FRAME_MAP, 'r017')
    for bad in hostile:
        on(node, bad)
        assert _fusion_state(node) == before
    assert sum(node.dropped.values()) == len(hostile)


def test_fusion_a_degenerate_track_does_not_stop_the_scoring_of_the_others(ros):
    """Defect 5: a zero/denormal covariance passed the PSD check, score() raised, nothing was published."""
    node, scores = _fusion(ros, pose_topics=['/radar/t0', '/radar/t1', '/patrol/t0'])
    t0 = _now(node)
    node._on_pose('/radar/t0', _report(t0, (0.0, 0.0)))
    node._on_pose('/patrol/t0', _report(t0, (0.5, 0.5)))
    for v in (0.0, 5e-324):
        node._on_pose('/radar/t1', _report(t0, (10.0, 0.0), np.diag([v, v])))
    assert node.dropped == {'/radar/t1': 2}
    node.tick()
    assert len(scores) == 1
    assert [{q.a, q.b} for q in scores[0].pairs] == [{'/radar/t0', '/patrol/t0'}]
    node._on_pose('/radar/t1', _report(t0 + 0.1, (10.0, 0.0)))  # the source recovers with a valid report
    node.tick()
    assert len(scores) == 2 and len(scores[1].pairs) == 2


def test_fusion_a_bad_track_of_an_array_is_refused_alone(ros):
    node, _ = _fusion(ros)
    t0 = _now(node)
    x = np.array([[0.0, 0.0, 0.0, 0.0], [np.nan, 0.0, 0.0, 0.0], [5.0, 0.0, 0.0, 0.0], [1.0, 0.0, 1.0, 0.0]])
    P = np.array([np.diag([4.0, 1.0, 3.0, 1.0])] * 4)
    node._on_track_array('/arrays', tracks_to_array(t0, ['a', 'b', 'a', 'c'], ['radar'] * 4, x, P))
    assert node.dropped == {'/arrays': 2}             # the NaN track and the second 'a'
    assert {'/arrays/a', '/arrays/c'} == set(node.core.table.latest)
    assert node.stamps.last('/arrays/b') is None


# --- slam -------------------------------------------------------------------------------------------------------

def _direct_slam(ros):
    """A slam node fed by calling its callbacks (deterministic); poses captured instead of published."""
    slam = ros.add(SlamNode(context=ros.context))
    poses = []
    slam.pub_pose.publish = poses.append
    return slam, poses


def _slam_state(slam):
    return frozen((slam.slam, slam.merger))


def _feed(slam, t, trees, speed=1.0):
    slam._on_scan(scan_to_pointcloud2(t, trees, np.full(len(trees), 0.3)))
    slam._on_input(inputs_to_twist(t + 0.05, speed, 0.0))


def _finite_pose(msg) -> bool:
    return bool(np.all(np.isfinite(odometry_to_pose(msg)[1])) and np.all(np.isfinite(odometry_to_pose(msg)[2])))


TREES = np.array([[10.0, 1.0], [12.0, 2.0], [15.0, 1.5]])


def test_far_future_stamp_is_refused_and_does_not_lock_the_input_stream(ros):
    """Issue 13 defect 1: an input stamped INT32_MAX s was accepted; every real input after it was refused."""
    slam, poses = _direct_slam(ros)
    slam._on_input(inputs_to_twist(1.0, 1.0, 0.0))
    _feed(slam, 1.05, TREES)
    assert slam.n_scans == 1 and len(poses) == 1
    before = _slam_state(slam)
    far = inputs_to_twist(1.2, 1.0, 0.0)
    far.header.stamp.sec = 2147483647
    slam._on_input(far)
    far_scan = scan_to_pointcloud2(1.2, TREES, np.full(3, 0.3))
    far_scan.header.stamp.sec = 2**31 - 10
    slam._on_scan(far_scan)
    assert _slam_state(slam) == before and slam.n_refused == 2
    _feed(slam, 1.3, TREES)  # both streams go on
    assert slam.n_refused == 2 and slam.merger.last_ns == {'inputs': 1_350_000_000, 'scan': 1_300_000_000}
    assert slam.n_scans == 2 and len(poses) == 2 and _finite_pose(poses[-1])


def test_huge_inputs_are_refused_and_huge_observations_dropped(ros):
    """Issue 13 defect 2: a finite 1e308 speed, range or diameter passed and left /slam/pose NaN for good."""
    slam, poses = _direct_slam(ros)
    slam._on_input(inputs_to_twist(1.0, 1.0, 0.0))
    _feed(slam, 1.05, TREES)
    before = _slam_state(slam)
    for speed in (1e308, -1e30, 2e4):
        slam._on_input(inputs_to_twist(1.2, speed, 0.0))
        assert _slam_state(slam) == before
    assert slam.n_bad_inputs == 3
    bad_r = np.vstack([TREES, [[1e308, 1.0], [5e7, 1.2]]])
    slam._on_scan(scan_to_pointcloud2(1.3, bad_r, np.full(5, 0.3)))
    slam._on_input(inputs_to_twist(1.35, 1.0, 0.0))
    slam._on_scan(scan_to_pointcloud2(1.4, TREES, np.array([0.3, 1e308, 0.3])))
    slam._on_input(inputs_to_twist(1.45, 1.0, 0.0))
    assert slam.n_dropped_obs == 3 and slam.n_scans == 3
    for k in range(2, 8):
        _feed(slam, 1.4 + 0.1 * k, TREES)
    assert all(_finite_pose(m) for m in poses) and len(poses) == 9
    lm, covs = slam.slam.map_estimate()
    assert np.all(np.isfinite(lm)) and np.all(np.isfinite(covs)) and np.all(np.abs(lm) < 100)


@pytest.mark.parametrize('n', [2_000, 100_000])
def test_an_oversized_scan_is_refused_whole_before_it_reaches_the_filter(ros, n):
    """A scan of 2,000 observations took the node to 4.5 GB (each one a new landmark of the state); 100k
    never answered: a scan beyond max_detections (default 500) is refused whole, the node goes on."""
    slam, poses = _direct_slam(ros)
    slam._on_input(inputs_to_twist(1.0, 1.0, 0.0))
    _feed(slam, 1.05, TREES)
    before = _slam_state(slam)
    rng = np.random.default_rng(0)
    flood = np.column_stack([rng.uniform(1.0, 60.0, n), rng.uniform(0.0, np.pi, n)])
    slam._on_scan(scan_to_pointcloud2(1.1, flood, np.full(n, 0.3)))
    assert _slam_state(slam) == before and slam.n_bad_scans == 1
    for k in range(2, 6):
        _feed(slam, 1.05 + 0.1 * k, TREES)
    assert len(poses) == 5 and all(_finite_pose(m) for m in poses)


# --- sonar_observer and smart_target ---------------------------------------------------------------------

def _sonar_nodes(ros, repo, cls, name):
    return ros.add(cls(node_name=name, context=ros.context,
                       cli_args=['--ros-args', '--params-file', str(repo / 'config/sonar.yaml')]))


def _bad_odometry(k: int):
    msg = cv_state_to_odometry(1.0 + k, np.ones(4), np.zeros((4, 4)), FRAME_MAP)
    if k % 3 == 0:
        msg.pose.pose.position.x = math.nan
    elif k % 3 == 1:
        msg.pose.pose.position.y = 1e308
    else:
        msg.header.frame_id = 'nowhere'
    return msg


def _bad_contact(k: int):
    """A contact that is wrong in one way each: NaN bearing, huge range, an unknown frame, a bad mode, a
    zero std, a stamp far in the future."""
    msg = contact_to_msg(Contact(10**9 * (1 + k), SensorMode.ACTIVE, 0.5, 300.0, np.diag([1e-4, 25.0])), FRAME_MAP)
    case = k % 6
    if case == 0:
        msg.bearing = math.nan
    elif case == 1:
        msg.range = 1e308
    elif case == 2:
        msg.header.frame_id = 'nowhere'
    elif case == 3:
        msg.mode = 7
    elif case == 4:
        msg.bearing_std = 0.0
    else:
        msg.header.stamp = sec_to_stamp(2e9)
    return msg


def test_sonar_observer_a_flood_of_bad_contacts_and_navigation_costs_a_few_log_lines(ros, repo):
    """Every bad contact and fix is refused with its reason, the filter untouched, the log throttled."""
    node = _sonar_nodes(ros, repo, SonarObserverNode, 'sonar_observer')
    lines = Lines(node)
    before = (frozen(node.tracker.particles), node.sequencer.key, len(node.sequencer.held))
    for k in range(300):
        node._on_contact(_bad_contact(k))
        node._on_nav(_bad_odometry(k))
    assert len(lines.warnings) <= 12, lines.warnings[:5]
    assert node.rejected == 600 and node.refusals.total() == 600
    assert (frozen(node.tracker.particles), node.sequencer.key, len(node.sequencer.held)) == before


def test_smart_target_a_flood_of_bad_pings_and_observers_costs_a_few_log_lines(ros, repo):
    """Defect 9: smart_target logged one line per dropped message."""
    from geometry_msgs.msg import PointStamped

    node = _sonar_nodes(ros, repo, SmartTargetNode, 'smart_target')
    lines = Lines(node)
    before = frozen(node.gate)
    for k in range(300):
        ping = PointStamped()
        ping.header.stamp, ping.header.frame_id = sec_to_stamp(1.0 + k), FRAME_MAP
        ping.point.x = (math.nan, 1e308, -1e9)[k % 3]
        node._on_ping(ping)
        node._on_observer(_bad_odometry(k))
    assert len(lines.warnings) <= 6, lines.warnings[:8]
    assert node.rejected == 600 and node.refusals.total() == 600 and frozen(node.gate) == before


# --- ais_nmea_source ------------------------------------------------------------------------------------

def _nmea_lines(fields: dict) -> list[bytes]:
    from pyais.encode import encode_dict

    return [x.encode() for x in encode_dict(fields, talker_id='AI', sentence_type='VDM')]


NMEA_OK = {'msg_type': 1, 'mmsi': 235000001, 'lat': 50.8, 'lon': -1.2, 'speed': 8.0, 'course': 30.0,
           'accuracy': 1}


def _nmea_source(ros, **params):
    from track_nodes.fusion.ais_nmea_source import AisNmeaSourceNode

    over = {'udp_port': _free_udp_port(), 'udp_address': '127.0.0.1', 'origin': [50.8, -1.2], 'stamp': 'receiver',
            'datum_wait': 0.0, **params}
    node = ros.add(AisNmeaSourceNode(context=ros.context,
                                     parameter_overrides=[Parameter(k, value=v) for k, v in over.items()]))
    assert ros.spin_until(lambda: node.datum is not None, timeout=5)
    out = []
    node.pub.publish = out.append
    return node, out


def _nmea_state(node):
    return frozen((node.ships.ships, node.published, node.datum.lat0, node.datum.lon0))


def test_nmea_nan_huge_and_out_of_range_sentences_are_refused_and_the_feed_goes_on(ros):
    """NaN/huge receiver times, out-of-range or "not available" positions, broken sentences: each refused with its
    reason, the ship table and the output untouched; a valid report after them is published."""
    from pyais import TagBlock

    node, out = _nmea_source(ros)
    lines = Lines(node)
    t0 = _now(node)
    (good,) = _nmea_lines(NMEA_OK)
    node._line(f'{t0:.3f} '.encode() + good, node.steady_now(), node.in_udp)
    assert len(out) == 1
    before = _nmea_state(node)
    huge = b'\\' + TagBlock.create(receiver_timestamp='1e308') + b'\\' + good
    hostile = [b'1e300 ' + good, huge, good[:-2] + b'ZZ', good[:25], b'nan', b'!AIVDM,1,1,,A,' + b'\xff' * 30,
               b'x' * 5000]
    hostile += _nmea_lines({**NMEA_OK, 'lat': 91.0}) + _nmea_lines({**NMEA_OK, 'lon': 181.0})   # not available
    hostile += _nmea_lines({**NMEA_OK, 'lat': 100.0}) + _nmea_lines({**NMEA_OK, 'lon': -200.0})  # out of range
    hostile += _nmea_lines({**NMEA_OK, 'mmsi': 0})
    hostile.append(f'{t0 - 3600:.3f} '.encode() + good)           # older than the ship's last report
    for bad in hostile:
        node._line(bad, node.steady_now(), node.in_udp)
        assert _nmea_state(node) == before, bad
    assert len(out) == 1 and node.refusals.total() == len(hostile), node.refusals.by_key()
    assert len(lines.warnings) <= len({k for _, k in node.refusals.counts}) + 1
    node._line(f'{t0 + 1:.3f} '.encode() + good, node.steady_now(), node.in_udp)
    assert len(out) == 2 and node.published == 2


def test_nmea_a_wrong_file_path_stops_the_node_with_one_line(ros):
    from track_nodes.base import ParameterError
    from track_nodes.fusion.ais_nmea_source import AisNmeaSourceNode

    with pytest.raises(ParameterError, match=r"parameter file='/nonexistent/capture.nmea': No such file"):
        AisNmeaSourceNode(context=ros.context, parameter_overrides=[
            Parameter('udp_port', value=0), Parameter('file', value='/nonexistent/capture.nmea')])


def test_nmea_a_udp_flood_is_read_in_bounded_bites_with_bounded_memory(ros):
    """5000 datagrams of garbage and orphan first fragments: refused or dropped and counted, a few log lines,
    the fragment buffer at its bound, the ship table untouched; valid reports after the flood still go out."""
    import socket

    from pyais.encode import encode_dict

    node, out = _nmea_source(ros, udp_port=_free_udp_port(), max_pending=16, max_datagrams=200)
    lines = Lines(node)
    before = _nmea_state(node)
    first_parts = [encode_dict({'msg_type': 5, 'mmsi': 235000000 + k, 'shipname': 'X'}, talker_id='AI',
                               sentence_type='VDM', seq_id=k % 10, radio_channel='AB'[k % 2])[0].encode()
                   for k in range(20)]
    flood = [b'garbage %d' % k if k % 2 else first_parts[k % 20] for k in range(5000)]
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as tx:
        for data in flood:
            tx.sendto(data, ('127.0.0.1', node.udp_port))
        # the kernel's socket buffer drops most of a burst: what arrives is read max_datagrams a poll
        assert ros.spin_until(lambda: node.decoder.sentences >= 200, timeout=20), node.decoder.sentences
        assert len(node.decoder.pending) <= 16 and _nmea_state(node) == before
        t = _now(node)
        (good,) = _nmea_lines(NMEA_OK)
        tx.sendto(f'{t + 10:.3f} '.encode() + good, ('127.0.0.1', node.udp_port))
        assert ros.spin_until(lambda: len(out) == 1, timeout=20), node.decoder.sentences
    assert node.refusals.total() >= node.decoder.sentences // 2 - 1
    assert len(lines.warnings) <= 3, lines.warnings[:5]


def _free_udp_port() -> int:
    import socket

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(('127.0.0.1', 0))
        return s.getsockname()[1]
