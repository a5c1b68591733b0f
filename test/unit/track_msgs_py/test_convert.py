"""Round trips between numpy and the standard messages, also through CDR (rclpy.serialization)."""

import math

import numpy as np
import pytest
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import PoseWithCovarianceStamped
from nav_msgs.msg import Odometry
from rclpy.serialization import deserialize_message, serialize_message
from sensor_msgs.msg import PointCloud2, PointField
from visualization_msgs.msg import Marker

from track_msgs_py.convert import (
    NOT_ESTIMATED_VARIANCE,
    PLANAR_VARIANCE,
    covariance_ellipse_marker,
    cv_state_to_odometry,
    diagnostic_array,
    diagnostic_status,
    ellipse_points,
    not_estimated,
    odometry_to_cv_state,
    odometry_to_pose,
    pointcloud2_to_table,
    pose_cov_to_position,
    pose_to_odometry,
    position_to_pose_cov,
    sec_to_stamp,
    stamp_to_ns,
    stamp_to_sec,
    table_to_pointcloud2,
)


def cdr(msg):
    """Serialise and deserialise: what a subscriber or a bag reader gets."""
    return deserialize_message(serialize_message(msg), type(msg))


# --- time -----------------------------------------------------------------------------------

@pytest.mark.parametrize(('t', 'sec', 'nanosec'), [
    (0.0, 0, 0),
    (1.5, 1, 500_000_000),
    (0.123456789, 0, 123_456_789),
    (1e-9, 0, 1),
    (0.9999999999, 1, 0),  # rounds up into the next second
    (4194303.999999999, 4194303, 999_999_999),
    (1_700_000_000.25, 1_700_000_000, 250_000_000),
    (float(2**31 - 1), 2**31 - 1, 0),
])
def test_sec_to_stamp_fixed_values(t, sec, nanosec):
    s = sec_to_stamp(t)
    assert (s.sec, s.nanosec) == (sec, nanosec)
    assert stamp_to_ns(s) == sec * 10**9 + nanosec


def test_float_stamp_float_is_exact_for_integer_nanoseconds_and_large_values():
    rng = np.random.default_rng(7)
    whole_ns = rng.integers(0, 2**22 * 10**9, 500) / 1e9  # floats nearest to integer nanoseconds
    epoch = rng.uniform(1.6e9, 1.8e9, 500)  # every float from 2**23 s on
    for t in [*whole_ns, *epoch, 0.1, 0.3, 1e-9, 12.375, 2.0**31 - 1]:
        assert stamp_to_sec(sec_to_stamp(t)) == t


def test_sub_nanosecond_fractions_are_rounded():
    assert stamp_to_ns(sec_to_stamp(62.5095466604667)) == 62_509_546_660
    assert stamp_to_ns(sec_to_stamp(2.0000000015)) == 2_000_000_002  # 1.5 ns (float just above) rounds up


def test_stamp_float_stamp_is_exact_for_integer_nanoseconds():
    rng = np.random.default_rng(8)
    secs = rng.integers(0, 2**22, 500)
    nsecs = rng.integers(0, 10**9, 500)
    for sec, ns in zip(secs, nsecs, strict=True):
        s = Time(sec=int(sec), nanosec=int(ns))
        back = sec_to_stamp(stamp_to_sec(s))
        assert (back.sec, back.nanosec) == (s.sec, s.nanosec)
    # beyond 2**22 s a float cannot hold every nanosecond: within 1 ulp, and stamp_to_ns stays exact
    big = Time(sec=1_700_000_000, nanosec=123_456_789)
    assert abs(stamp_to_ns(sec_to_stamp(stamp_to_sec(big))) - stamp_to_ns(big)) <= 240
    assert stamp_to_ns(cdr(big)) == 1_700_000_000_123_456_789


@pytest.mark.parametrize('t', [-1e-9, -1.0, math.nan, math.inf, 2.0**31])
def test_sec_to_stamp_rejects_negative_non_finite_and_overflow(t):
    with pytest.raises(ValueError, match='stamp'):
        sec_to_stamp(t)


# --- odometry -------------------------------------------------------------------------------

X = np.array([3.0, -1.25, -7.5, 0.5])
P = np.array([
    [4.0, 0.6, 0.3, 0.1],
    [0.6, 0.9, 0.05, 0.02],
    [0.3, 0.05, 2.5, -0.4],
    [0.1, 0.02, -0.4, 0.7],
])


@pytest.mark.parametrize('through_cdr', [False, True])
def test_odometry_round_trip_keeps_blocks_and_drops_cross_covariance(through_cdr):
    msg = cv_state_to_odometry(12.375, X, P, 'map', 'track_7')
    if through_cdr:
        msg = cdr(msg)
    assert msg.header.frame_id == 'map' and msg.child_frame_id == 'track_7'
    t, x, P2 = odometry_to_cv_state(msg)
    assert t == 12.375
    np.testing.assert_array_equal(x, X)
    pos, vel = np.ix_([0, 2], [0, 2]), np.ix_([1, 3], [1, 3])
    np.testing.assert_array_equal(P2[pos], P[pos])
    np.testing.assert_array_equal(P2[vel], P[vel])
    expected = np.zeros((4, 4))
    expected[pos], expected[vel] = P[pos], P[vel]
    np.testing.assert_array_equal(P2, expected)  # position–velocity cross blocks are zero


def test_odometry_field_layout():
    msg = cv_state_to_odometry(1.0, X, P)
    assert msg.header.frame_id == 'map' and msg.child_frame_id == ''
    assert (msg.pose.pose.position.x, msg.pose.pose.position.y, msg.pose.pose.position.z) == (3.0, -7.5, 0.0)
    q = msg.pose.pose.orientation
    assert (q.x, q.y, q.z, q.w) == (0.0, 0.0, 0.0, 1.0)
    assert (msg.twist.twist.linear.x, msg.twist.twist.linear.y) == (-1.25, 0.5)
    pose_cov = np.asarray(msg.pose.covariance).reshape(6, 6)
    twist_cov = np.asarray(msg.twist.covariance).reshape(6, 6)
    np.testing.assert_array_equal(pose_cov[:2, :2], [[4.0, 0.3], [0.3, 2.5]])
    np.testing.assert_array_equal(twist_cov[:2, :2], [[0.9, 0.02], [0.02, 0.7]])
    for cov in (pose_cov, twist_cov):  # issue 19: z/roll/pitch 0 (planar, RViz's 2-D mode), yaw not estimated
        np.testing.assert_array_equal(np.diag(cov)[2:], [PLANAR_VARIANCE] * 3 + [NOT_ESTIMATED_VARIANCE])
        assert PLANAR_VARIANCE == 0.0 and not_estimated(cov[5, 5]) and not not_estimated(cov[:2, :2]).any()
        off = cov - np.diag(np.diag(cov))
        off[:2, :2] = 0.0
        assert not off.any()


def test_slam_pose_covariance_is_planar_with_the_twist_not_estimated():
    P3 = np.array([[0.5, 0.1, 0.02], [0.1, 0.4, -0.01], [0.02, -0.01, 0.003]])
    msg = cdr(pose_to_odometry(2.5, np.array([1.0, 2.0, 0.3]), P3))
    pose_cov = np.asarray(msg.pose.covariance).reshape(6, 6)
    twist_cov = np.asarray(msg.twist.covariance).reshape(6, 6)
    idx = np.ix_([0, 1, 5], [0, 1, 5])
    np.testing.assert_array_equal(pose_cov[idx], P3)
    rest = pose_cov.copy()
    rest[idx] = 0.0
    assert not rest.any()  # z, roll, pitch and their cross terms: exactly 0 (RViz's 2-D mode)
    np.testing.assert_array_equal(np.diag(twist_cov), [1e6, 1e6, 0.0, 0.0, 0.0, 1e6])
    assert not_estimated(np.diag(twist_cov)).tolist() == [True, True, False, False, False, True]
    np.testing.assert_array_equal(odometry_to_pose(msg)[2], P3)


def test_odometry_rejects_wrong_shapes():
    with pytest.raises(ValueError, match='x must have shape'):
        cv_state_to_odometry(0.0, X[:3], P)
    with pytest.raises(ValueError, match='P must have shape'):
        cv_state_to_odometry(0.0, X, P[:2, :2])


# --- pose with covariance -------------------------------------------------------------------

@pytest.mark.parametrize('through_cdr', [False, True])
def test_pose_cov_round_trip(through_cdr):
    z, R = np.array([101.5, -0.25]), np.array([[2.0, -0.7], [-0.7, 1.0]])
    msg = position_to_pose_cov(1_700_000_000.5, z, R, 'map')
    assert isinstance(msg, PoseWithCovarianceStamped)
    if through_cdr:
        msg = cdr(msg)
    t, z2, R2 = pose_cov_to_position(msg)
    assert t == 1_700_000_000.5 and msg.header.frame_id == 'map'
    np.testing.assert_array_equal(z2, z)
    np.testing.assert_array_equal(R2, R)
    assert msg.pose.pose.position.z == 0.0 and msg.pose.pose.orientation.w == 1.0
    np.testing.assert_array_equal(np.diag(np.asarray(msg.pose.covariance).reshape(6, 6))[2:], [0.0, 0.0, 0.0, 1e6])


# --- PointCloud2 tables ---------------------------------------------------------------------

@pytest.mark.parametrize('n', [0, 1, 7, 20_000])
@pytest.mark.parametrize('through_cdr', [False, True])
def test_pointcloud2_round_trip(n, through_cdr):
    rng = np.random.default_rng(n)
    table = {'x': rng.normal(size=n), 'y': rng.normal(size=n) * 1e3, 'phase': rng.uniform(-np.pi, np.pi, n),
             'weight': rng.uniform(size=n)}
    msg = table_to_pointcloud2(4.5, 'map', table)
    assert (msg.height, msg.width, msg.point_step, msg.row_step) == (1, n, 16, 16 * n)
    assert [(f.name, f.offset, f.datatype, f.count) for f in msg.fields] == [
        ('x', 0, PointField.FLOAT32, 1), ('y', 4, PointField.FLOAT32, 1),
        ('phase', 8, PointField.FLOAT32, 1), ('weight', 12, PointField.FLOAT32, 1)]
    assert len(msg.data) == 16 * n and msg.is_dense and not msg.is_bigendian
    if through_cdr:
        msg = cdr(msg)
    assert stamp_to_sec(msg.header.stamp) == 4.5
    back = pointcloud2_to_table(msg)
    assert list(back) == list(table)
    for name, col in table.items():
        assert back[name].dtype == np.float64 and back[name].shape == (n,)
        np.testing.assert_array_equal(back[name], col.astype(np.float32))


def test_points_come_first_as_float32_xyz():
    from track_msgs_py.convert import cloud_columns, points_to_pointcloud2

    xy = np.array([[1.0, 2.0], [3.0, -4.0]])
    msg = cdr(points_to_pointcloud2(1.0, 'map', xy, {'p': np.array([0.25, 0.75])}))
    assert [(f.name, f.offset, f.datatype, f.count) for f in msg.fields] == [
        ('x', 0, PointField.FLOAT32, 1), ('y', 4, PointField.FLOAT32, 1), ('z', 8, PointField.FLOAT32, 1),
        ('p', 12, PointField.FLOAT32, 1)]
    table = pointcloud2_to_table(msg)
    np.testing.assert_array_equal(np.stack([table['x'], table['y']], 1), xy)
    np.testing.assert_array_equal(table['z'], [0.0, 0.0])
    assert list(cloud_columns(table)) == ['p']
    xyz = pointcloud2_to_table(points_to_pointcloud2(0.0, 'map', np.array([[1.0, 2.0, 3.0]]), {}))
    assert (xyz['x'][0], xyz['y'][0], xyz['z'][0]) == (1.0, 2.0, 3.0)
    with pytest.raises(ValueError, match='clash'):
        points_to_pointcloud2(0.0, 'map', xy, {'z': np.zeros(2)})
    with pytest.raises(ValueError, match='shape'):
        points_to_pointcloud2(0.0, 'map', np.zeros((2, 4)), {})


def test_scan_points_are_in_the_laser_frame_of_the_slam_pose():
    """x ahead, y left: the point put in map by the pose (x, y, φ) is where inverse_observe puts the landmark."""
    from track_core.slam.models import inverse_observe
    from track_msgs_py.convert import scan_points

    z = np.array([[10.0, math.pi / 2], [5.0, 0.0], [2.0, math.pi], [7.0, 0.4]])  # ahead, right, left, ...
    pts = scan_points(z)
    np.testing.assert_allclose(pts[:3], [[10.0, 0.0], [0.0, -5.0], [0.0, 2.0]], atol=1e-12)
    pose = np.array([3.0, -1.0, 0.7])
    c, s = math.cos(pose[2]), math.sin(pose[2])
    in_map = pose[:2] + pts @ np.array([[c, s], [-s, c]])
    np.testing.assert_allclose(in_map, inverse_observe(pose, z), atol=1e-12)


def test_pointcloud2_marks_non_finite_values_not_dense():
    msg = table_to_pointcloud2(0.0, 'map', {'a': np.array([1.0, np.nan]), 'b': np.array([0.0, 1.0])})
    assert not msg.is_dense
    assert np.isnan(pointcloud2_to_table(msg)['a'][1])


@pytest.mark.parametrize('fields', [{}, {'a': np.zeros(3), 'b': np.zeros(4)}, {'a': np.zeros((3, 2))}])
def test_pointcloud2_rejects_bad_tables(fields):
    with pytest.raises(ValueError, match='field'):
        table_to_pointcloud2(0.0, 'map', fields)


def test_pointcloud2_reads_foreign_layout():
    """Another producer: float64 + uint16 fields, big-endian, padded points and rows, height 2."""
    dtype = np.dtype({'names': ['range', 'id'], 'formats': ['>f8', '>u2'], 'offsets': [0, 8], 'itemsize': 12})
    pts = np.zeros((2, 3), dtype)
    pts['range'] = [[1.5, 2.5, 3.5], [4.5, 5.5, 6.5]]
    pts['id'] = [[1, 2, 3], [4, 5, 6]]
    rows = np.zeros((2, 40), np.uint8)  # row_step 40 > width * point_step = 36
    rows[:, :36] = pts.view(np.uint8).reshape(2, 36)
    msg = PointCloud2(height=2, width=3, is_bigendian=True, point_step=12, row_step=40,
                      fields=[PointField(name='range', offset=0, datatype=PointField.FLOAT64, count=1),
                              PointField(name='id', offset=8, datatype=PointField.UINT16, count=1)])
    msg.data = rows.tobytes()
    back = pointcloud2_to_table(cdr(msg))
    np.testing.assert_array_equal(back['range'], [1.5, 2.5, 3.5, 4.5, 5.5, 6.5])
    np.testing.assert_array_equal(back['id'], [1, 2, 3, 4, 5, 6])


def test_pointcloud2_too_short_data_is_an_error():
    msg = table_to_pointcloud2(0.0, 'map', {'a': np.arange(4.0)})
    msg.data = msg.data[:-4]
    with pytest.raises(ValueError, match='too short'):
        pointcloud2_to_table(msg)


# --- markers and diagnostics ----------------------------------------------------------------

@pytest.mark.parametrize('R', [
    np.array([[4.0, 0.0], [0.0, 1.0]]),
    np.array([[2.0, 1.2], [1.2, 1.0]]),
    np.array([[1e-4, -3e-5], [-3e-5, 2e-4]]),
])
def test_ellipse_marker_points_lie_on_the_two_sigma_contour(R):
    mu = np.array([10.0, -3.0])
    msg = covariance_ellipse_marker(2.0, mu, R, 'map', marker_id=3, n_points=50)
    assert msg.type == Marker.LINE_STRIP and msg.action == Marker.ADD and msg.id == 3
    pts = np.array([[p.x, p.y] for p in cdr(msg).points])
    assert pts.shape == (51, 2)
    np.testing.assert_array_equal(pts[0], pts[-1])  # closed loop
    d = pts - mu
    q = np.einsum('ni,ij,nj->n', d, np.linalg.inv(R), d)
    np.testing.assert_allclose(q, 4.0, rtol=0, atol=1e-9)
    # the points go round the whole ellipse, not one arc
    ang = np.unwrap(np.arctan2(d[:, 1], d[:, 0]))
    assert abs(abs(ang[-1] - ang[0]) - 2 * np.pi) < 1e-9


def test_ellipse_points_scale_with_n_sigma_and_reject_bad_covariance():
    R = np.array([[2.0, 0.5], [0.5, 1.0]])
    np.testing.assert_allclose(ellipse_points(np.zeros(2), R, 3.0), 1.5 * ellipse_points(np.zeros(2), R, 2.0))
    with pytest.raises(ValueError, match='positive semi-definite'):
        ellipse_points(np.zeros(2), np.array([[1.0, 2.0], [2.0, 1.0]]))


def test_diagnostic_status_and_array():
    st = diagnostic_status('demo_tracker', 1, 'dropped reports', {'rejected': 3, 'nees': 4.25}, hardware_id='hw')
    st2 = cdr(st)
    assert st2.level == DiagnosticStatus.WARN and st2.name == 'demo_tracker' and st2.hardware_id == 'hw'
    assert [(kv.key, kv.value) for kv in st2.values] == [('rejected', '3'), ('nees', '4.25')]
    assert diagnostic_status('x', DiagnosticStatus.ERROR, '', {}).level == DiagnosticStatus.ERROR
    arr = cdr(diagnostic_array(3.0, [st]))
    assert isinstance(arr, DiagnosticArray) and stamp_to_sec(arr.header.stamp) == 3.0 and len(arr.status) == 1
    with pytest.raises(ValueError, match='level'):
        diagnostic_status('x', 4, '', {})


def test_odometry_type_is_the_standard_one():
    assert isinstance(cv_state_to_odometry(0.0, X, P), Odometry)


def test_pose_array_round_trip():
    from track_msgs_py.convert import pose_array_to_positions, positions_to_pose_array

    rng = np.random.default_rng(0)
    xy, th = rng.normal(size=(50, 2)), rng.uniform(-3.1, 3.1, 50)
    msg = positions_to_pose_array(2.5, xy, headings=th)
    assert len(msg.poses) == 50 and msg.header.stamp.sec == 2
    xy2, th2 = pose_array_to_positions(msg)
    np.testing.assert_allclose(xy2, xy, atol=1e-12)
    np.testing.assert_allclose(th2, th, atol=1e-12)
    _, th0 = pose_array_to_positions(positions_to_pose_array(0.0, xy))
    assert np.all(th0 == 0.0)


# --- IDSQ layout and handoff ----------------------------------------------------------------

@pytest.mark.parametrize('through_cdr', [False, True])
def test_idsq_layout_round_trip_is_exact(through_cdr):
    from track_core.idsq import SensorLayout
    from track_msgs_py.convert import LAYOUT_FIELDS, layout_to_pointcloud2, pointcloud2_to_layout

    rng = np.random.default_rng(3)
    layout = SensorLayout(rng.uniform(0.0, 150.0, (12, 2)) + 1e-9 * rng.standard_normal((12, 2)),
                          rng.random(12) < 0.3, 40.0)
    msg = layout_to_pointcloud2(1.5, layout)
    assert [f.name for f in msg.fields] == ['x', 'y', 'z', *LAYOUT_FIELDS] and msg.width == 12
    assert [(f.offset, f.datatype) for f in msg.fields[:3]] == [(0, PointField.FLOAT32), (4, PointField.FLOAT32),
                                                               (8, PointField.FLOAT32)]
    assert all(f.datatype == PointField.FLOAT64 and f.offset % 8 == 0 for f in msg.fields[3:])
    table = pointcloud2_to_table(msg)
    np.testing.assert_array_equal(table['x'], layout.positions[:, 0].astype(np.float32))
    assert not table['z'].any()
    back = pointcloud2_to_layout(cdr(msg) if through_cdr else msg, 40.0)
    np.testing.assert_array_equal(back.positions, layout.positions)  # float64: bit-exact
    np.testing.assert_array_equal(back.is_doa, layout.is_doa)
    assert all(np.array_equal(a, b) for a, b in zip(back.neighbours, layout.neighbours, strict=True))


def test_idsq_layout_reader_sorts_by_id_and_refuses_bad_clouds():
    from track_msgs_py.convert import pointcloud2_to_layout

    xy = np.array([[0.0, 0.0], [10.0, 0.0], [0.0, 10.0]])
    shuffled = table_to_pointcloud2(0.0, 'map', {'id': [2, 0, 1], 'x': xy[[2, 0, 1], 0], 'y': xy[[2, 0, 1], 1],
                                                 'type': [1, 0, 0]})
    back = pointcloud2_to_layout(shuffled, 40.0)
    np.testing.assert_array_equal(back.positions, xy)
    np.testing.assert_array_equal(back.is_doa, [False, False, True])
    for fields, reason in [({'id': [0, 1], 'x': [0, 1], 'y': [0, 1]}, 'no field.*type'),
                           ({'id': [0, 2], 'x': [0, 1], 'y': [0, 1], 'type': [0, 0]}, 'ids must be 0..1'),
                           ({'id': [0, 1], 'x': [0, 1], 'y': [0, 1], 'type': [0, 2]}, 'type must be 0')]:
        with pytest.raises(ValueError, match=reason):
            pointcloud2_to_layout(table_to_pointcloud2(0.0, 'map', fields), 40.0)


@pytest.mark.parametrize('through_cdr', [False, True])
def test_idsq_handoff_message_round_trip(through_cdr):
    from std_msgs.msg import UInt8MultiArray

    from track_core.idsq import GridSpec, Handoff, encode_handoff, receive_handoff
    from track_msgs_py.convert import HANDOFF_LABEL, handoff_to_uint8_array, uint8_array_to_handoff

    grid = GridSpec.for_field()
    payload = encode_handoff(Handoff(4, 1, 2, grid, np.array([3, 8, 40]), np.array([0.5, 0.25, 0.25])))
    msg = handoff_to_uint8_array(payload)
    assert isinstance(msg, UInt8MultiArray)
    assert [(d.label, d.size, d.stride) for d in msg.layout.dim] == [(HANDOFF_LABEL, len(payload), len(payload))]
    data = uint8_array_to_handoff(cdr(msg) if through_cdr else msg)
    assert isinstance(data, bytes) and data == payload
    h, why = receive_handoff(data, grid, receiver=2)
    assert why is None and (h.step, h.sender, h.receiver) == (4, 1, 2)
    assert uint8_array_to_handoff(handoff_to_uint8_array(b'')) == b''
