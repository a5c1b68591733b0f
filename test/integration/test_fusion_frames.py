"""fusion with inputs in any frame: a radar frame moving with its ship on /tf scores as its map-frame copy;
a REP-105 Odometry scores as its map-frame copy; an unknown frame or a too-old transform is refused."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
from geometry_msgs.msg import PoseWithCovarianceStamped
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock
from tf2_msgs.msg import TFMessage

from track_msgs.msg import PairScoreArray, TrackArray
from track_msgs_py.odometry import cv_state_to_odometry
from track_msgs_py.qos import CLOCK_QOS, ESTIMATE_QOS
from track_msgs_py.records.fusion import FusionPairs
from track_msgs_py.stamps import sec_to_stamp
from track_msgs_py.tf import TF_QOS, TF_STATIC_QOS, planar_transform
from track_msgs_py.topics import FUSION_SCORES
from track_msgs_py.track_arrays import tracks_to_array
from track_nodes.fusion.fusion import ARRAY_QOS, FusionNode

pytestmark = pytest.mark.integration

DT = 0.05                         # the fusion's step for a moving frame's velocity (tf_buffer.DT)
SHIP_V, SHIP_W = np.array([4.0, 1.5]), 0.02      # the ship's velocity [m/s] and turn rate [rad/s]
RADAR_AT, RADAR_YAW = np.array([2.0, 1.0]), 0.5   # the radar on the ship (static)


def _rot(a):
    return np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])


def _ship(t, t0):
    s = t - t0
    return np.array([100.0, 50.0]) + SHIP_V * s, 0.3 + SHIP_W * s


def _target(t, t0):
    """The true target in map: position, velocity and covariance of the state [x, vx, y, vy]."""
    s = t - t0
    p, v = np.array([400.0, 300.0]) + np.array([-3.0, 2.0]) * s, np.array([-3.0, 2.0])
    P = np.zeros((4, 4))
    P[np.ix_([0, 2], [0, 2])] = _rot(0.4) @ np.diag([20.0**2, 8.0**2]) @ _rot(0.4).T
    P[np.ix_([1, 3], [1, 3])] = np.diag([0.5**2, 0.3**2])
    return np.array([p[0], v[0], p[1], v[1]]), P


def _in_radar(x, P, t, t0):
    """The map state seen from the radar frame, written out here independently of the fusion's code."""
    ship, yaw = _ship(t, t0)
    o = ship + _rot(yaw) @ RADAR_AT                              # radar origin in map
    R = _rot(yaw + RADAR_YAW)
    Om = np.array([[0.0, -SHIP_W], [SHIP_W, 0.0]])
    o_dot = SHIP_V + Om @ (_rot(yaw) @ RADAR_AT)
    p, v = x[[0, 2]], x[[1, 3]]
    pr = R.T @ (p - o)
    vr = R.T @ (v - o_dot - Om @ (p - o))
    A = np.zeros((4, 4))
    A[np.ix_([0, 2], [0, 2])] = R.T
    A[np.ix_([1, 3], [1, 3])] = R.T
    A[np.ix_([1, 3], [0, 2])] = -R.T @ Om
    return np.array([pr[0], vr[0], pr[1], vr[1]]), A @ P @ A.T


def _rep105(t, x, P) -> Odometry:
    """The map state as REP-105 odometry: the pose's orientation is the heading, the twist (and its
    covariance) along the body's axes."""
    heading = math.atan2(x[3], x[1])
    body = cv_state_to_odometry(t, x, P, 'map', 't')
    body.pose.pose.orientation.z, body.pose.pose.orientation.w = math.sin(heading / 2), math.cos(heading / 2)
    Rh = _rot(heading)
    vb = Rh.T @ x[[1, 3]]
    body.twist.twist.linear.x, body.twist.twist.linear.y = float(vb[0]), float(vb[1])
    cov = np.array(body.twist.covariance).reshape(6, 6)
    cov[:2, :2] = Rh.T @ P[np.ix_([1, 3], [1, 3])] @ Rh
    body.twist.covariance = cov.ravel().tolist()
    return body


def _has_sample(edges, child, t) -> bool:
    """The fusion's transform buffer holds the sample of ``child`` stamped ``t``."""
    return child in edges and abs(edges[child].times[-1] - t) < 1e-9


def _holds(table, ids, t) -> bool:
    """The fusion holds the report of instant ``t`` of every track ``ids``."""
    return all(i in table and abs(table[i].t - t) < 1e-6 for i in ids)


def _fusion(ros, **extra):
    params = {'track_array_topics': ['/a/radar', '/a/map', '/a/other', '/a/lost'],
              'odometry_topics': ['/o/rep105', '/o/map'], 'rate': 10.0, 'stale_after': 5.0, 'window': 5,
              'max_prediction': 30.0, **extra}
    node = ros.add(FusionNode(node_name='fusion', context=ros.context,
                              parameter_overrides=[Parameter(k, value=v) for k, v in params.items()]))
    reasons: list[tuple[str, str]] = []
    drop = node._drop
    node._drop = lambda topic, reason: (reasons.append((topic, reason)), drop(topic, reason))
    return node, reasons


def test_inputs_in_a_moving_radar_frame_and_rep105_odometry_score_as_their_map_copies(ros):
    """On sim time, one instant at a time: the transforms, then the inputs of instant t, then /clock at t and
    a scoring; every step waits for a condition (the fusion holds the inputs of t), so load changes nothing."""
    node, reasons = _fusion(ros, use_sim_time=True, rate=0.01)   # the test takes the instants, not the timer
    src = ros.add(Node('sources', context=ros.context))
    pubs = {t: src.create_publisher(TrackArray, t, ARRAY_QOS) for t in ('/a/radar', '/a/map', '/a/other', '/a/lost')}
    odo = {t: src.create_publisher(Odometry, t, ESTIMATE_QOS) for t in ('/o/rep105', '/o/map')}
    tf = src.create_publisher(TFMessage, '/tf', TF_QOS)
    tf_static = src.create_publisher(TFMessage, '/tf_static', TF_STATIC_QOS)
    clock = src.create_publisher(Clock, '/clock', CLOCK_QOS)
    latest: dict[frozenset, float] = {}

    def on_scores(msg):
        for (a, b), score, *_ in FusionPairs.from_msg(msg).rows():
            latest[frozenset((a, b))] = score

    src.create_subscription(PairScoreArray, FUSION_SCORES, on_scores, ESTIMATE_QOS)
    assert ros.spin_until(lambda: all(node.count_publishers(t) >= 1 for t in ('/a/radar', '/o/map', '/clock'))
                          and src.count_subscribers('/tf_static') >= 1, timeout=30)
    tf_static.publish(TFMessage(transforms=[planar_transform(0.0, 'ship', 'radar', *RADAR_AT, RADAR_YAW)]))
    t0 = 1_000.0
    rng = np.random.default_rng(3)
    offset = np.array([25.0, 0.0, -20.0, 0.0])      # a partial overlap of the two 2σ ellipses
    ids = ('/a/radar/t', '/a/map/t', '/a/other/t', '/o/rep105/t', '/o/map/t')
    for k in range(20):
        t = t0 + 0.1 * k
        clock.publish(Clock(clock=sec_to_stamp(t)))
        assert ros.spin_until(lambda t=t: abs(node.get_clock().now().nanoseconds * 1e-9 - t) < 1e-6, timeout=30)
        tf.publish(TFMessage(transforms=[planar_transform(s, 'map', 'ship', *_ship(s, t0)[0], _ship(s, t0)[1])
                                         for s in (t - DT, t)]))
        # the sample at t itself, not the last one within the tolerance
        assert ros.spin_until(lambda t=t: _has_sample(node.tf.edges, 'ship', t), timeout=30)
        x, P = _target(t, t0)
        xr, Pr = _in_radar(x, P, t, t0)
        other = x + offset + np.r_[rng.normal(0, 3), 0, rng.normal(0, 3), 0]
        pubs['/a/radar'].publish(tracks_to_array(t, ['t'], ['radar'], xr[None], Pr[None], 'radar'))
        pubs['/a/map'].publish(tracks_to_array(t, ['t'], ['map'], x[None], P[None], 'map'))
        pubs['/a/other'].publish(tracks_to_array(t, ['t'], ['other'], other[None], P[None], 'map'))
        odo['/o/rep105'].publish(_rep105(t, x, P))
        odo['/o/map'].publish(cv_state_to_odometry(t, x, P, 'map', 't'))
        assert ros.spin_until(lambda t=t: _holds(node.core.table.latest, ids, t) or reasons,
                              timeout=30), (sorted(node.core.table.latest), reasons)
        node.tick()
    pairs = {name: frozenset(ids) for name, ids in {
        'radar-other': ('/a/radar/t', '/a/other/t'), 'map-other': ('/a/map/t', '/a/other/t'),
        'radar-map': ('/a/radar/t', '/a/map/t'), 'rep105-other': ('/o/rep105/t', '/a/other/t'),
        'odomap-other': ('/o/map/t', '/a/other/t')}.items()}
    assert ros.spin_until(lambda: all(p in latest for p in pairs.values()), timeout=10), (sorted(latest), reasons)
    s = {name: latest[p] for name, p in pairs.items()}
    assert not [r for r in reasons if r[0] in ('/a/radar', '/o/rep105')], reasons
    assert 0.05 < s["map-other"] < 0.99                          # an informative pair, not saturated
    assert s['radar-other'] == pytest.approx(s['map-other'], abs=2e-3), s
    assert s['radar-map'] > 0.99, s                                # the two copies of one track coincide
    assert s['rep105-other'] == pytest.approx(s['odomap-other'], abs=1e-6), s


def test_unknown_frame_and_too_old_transform_are_refused_with_the_frame(ros):
    node, reasons = _fusion(ros, tf_tolerance=0.2)
    src = ros.add(Node('sources', context=ros.context))
    pub_lost = src.create_publisher(TrackArray, '/a/lost', ARRAY_QOS)
    pub_radar = src.create_publisher(TrackArray, '/a/radar', ARRAY_QOS)
    tf = src.create_publisher(TFMessage, '/tf', TF_QOS)
    assert ros.spin_until(lambda: node.count_publishers('/a/lost') >= 1 and node.count_publishers('/a/radar') >= 1
                          and src.count_subscribers('/tf') >= 1, timeout=10)
    t = time.time()
    x, P = _target(t, t)
    tf.publish(TFMessage(transforms=[planar_transform(t - 1.0, 'map', 'radar', 0.0, 0.0, 0.0)]))
    ros.spin_until(lambda: bool(node.tf.edges), timeout=5)
    pub_lost.publish(tracks_to_array(t, ['t'], ['x'], x[None], P[None], 'nowhere'))
    pub_radar.publish(tracks_to_array(t, ['t'], ['x'], x[None], P[None], 'radar'))     # 1 s after its transform
    assert ros.spin_until(lambda: len(reasons) >= 2, timeout=10), reasons
    why = dict(reasons)
    assert "unknown frame 'nowhere'" in why['/a/lost']
    assert 'too old' in why['/a/radar'] and "'radar'" in why['/a/radar']
    assert node.dropped == {'/a/lost': 1, '/a/radar': 1}


def test_a_navsatfix_enters_through_the_run_datum_with_its_covariance(ros):
    """A GNSS fix is refused until a datum is on map_datum, then placed where the datum's projection puts it, with
    its east/north covariance turned to grid north; it scores against a map-frame copy of itself as one ship."""
    from sensor_msgs.msg import NavSatFix

    from track_core.ais.datum import Datum
    from track_msgs_py.ais import datum_to_navsatfix
    from track_msgs_py.odometry import position_to_pose_cov
    from track_msgs_py.qos import STATIC_QOS
    from track_msgs_py.stamps import sec_to_stamp

    node, reasons = _fusion(ros, track_array_topics=[''], odometry_topics=[''], navsatfix_topics=['/gps/fix'],
                            pose_topics=['/radar/own'])
    src = ros.add(Node('sources', context=ros.context))
    fix_pub = src.create_publisher(NavSatFix, '/gps/fix', ESTIMATE_QOS)
    pose_pub = src.create_publisher(PoseWithCovarianceStamped, '/radar/own', ESTIMATE_QOS)
    datum_pub = src.create_publisher(NavSatFix, '/map_datum', STATIC_QOS)
    assert ros.spin_until(lambda: node.count_publishers('/gps/fix') >= 1 and node.count_publishers('/radar/own') >= 1,
                          timeout=10)
    lat, lon, cov = 50.80, -0.80, np.array([[16.0, 6.0], [6.0, 36.0]])     # 28 km east of the origin below

    def fix(t, covariance_type=NavSatFix.COVARIANCE_TYPE_KNOWN):
        msg = NavSatFix(latitude=lat, longitude=lon, altitude=3.0, position_covariance_type=covariance_type)
        msg.header.stamp, msg.header.frame_id = sec_to_stamp(t), 'gps'
        msg.status.status = 0
        msg.position_covariance = [cov[0, 0], cov[0, 1], 0.0, cov[1, 0], cov[1, 1], 0.0, 0.0, 0.0, 100.0]
        return msg

    fix_pub.publish(fix(time.time()))
    assert ros.spin_until(lambda: reasons, timeout=10)
    assert reasons[0][0] == '/gps/fix' and 'no map datum known yet (none on /map_datum)' in reasons[0][1]
    datum = Datum(50.8, -1.2)
    datum_pub.publish(datum_to_navsatfix(time.time(), 50.8, -1.2))
    assert ros.spin_until(lambda: node.map_datum.datum is not None, timeout=10)
    fix_pub.publish(fix(time.time(), NavSatFix.COVARIANCE_TYPE_UNKNOWN))
    assert ros.spin_until(lambda: len(reasons) >= 2, timeout=10)
    assert 'position_covariance_type: unknown' in reasons[1][1]
    t = time.time()
    fix_pub.publish(fix(t))
    assert ros.spin_until(lambda: '/gps/fix' in node.core.table.latest, timeout=10), reasons
    report = node.core.table.latest['/gps/fix']
    z, R = datum.forward(lat, lon), datum.to_map_covariance(lat, lon, cov)
    np.testing.assert_allclose(report.mu, z, atol=1e-6)
    np.testing.assert_allclose(report.R, R, atol=1e-9)
    assert abs(R[0, 1] - cov[0, 1]) > 0.05                          # γ = 0.31° turned it (an independent check:
    assert np.trace(R) == pytest.approx(np.trace(cov))              # test_datum.py's Jacobian)
    assert node.core.source['/gps/fix'] == '/gps'
    pose_pub.publish(position_to_pose_cov(t, z, R, 'map'))          # the same ship seen by a radar in map
    assert ros.spin_until(lambda: ('/gps/fix', '/radar/own') in node.core.history
                          or ('/radar/own', '/gps/fix') in node.core.history, timeout=10)
