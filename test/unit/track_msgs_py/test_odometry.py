"""Tracks, reports and poses ⇄ Odometry, PoseWithCovarianceStamped and PoseArray, also through CDR."""

import math

import numpy as np
import pytest
from geometry_msgs.msg import PoseWithCovarianceStamped
from nav_msgs.msg import Odometry
from rclpy.serialization import deserialize_message, serialize_message

from track_msgs_py.covariance import NOT_ESTIMATED_VARIANCE, PLANAR_VARIANCE, not_estimated
from track_msgs_py.odometry import (
    cv_state_to_odometry,
    odometry_to_cv_state,
    odometry_to_pose,
    pose_array_to_positions,
    pose_cov_to_position,
    pose_to_odometry,
    position_to_pose_cov,
    positions_to_pose_array,
)


def cdr(msg):
    """Serialise and deserialise: what a subscriber or a bag reader gets."""
    return deserialize_message(serialize_message(msg), type(msg))


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


def test_odometry_type_is_the_standard_one():
    assert isinstance(cv_state_to_odometry(0.0, X, P), Odometry)


def test_pose_array_round_trip():
    rng = np.random.default_rng(0)
    xy, th = rng.normal(size=(50, 2)), rng.uniform(-3.1, 3.1, 50)
    msg = positions_to_pose_array(2.5, xy, headings=th)
    assert len(msg.poses) == 50 and msg.header.stamp.sec == 2
    xy2, th2 = pose_array_to_positions(msg)
    np.testing.assert_allclose(xy2, xy, atol=1e-12)
    np.testing.assert_allclose(th2, th, atol=1e-12)
    _, th0 = pose_array_to_positions(positions_to_pose_array(0.0, xy))
    assert np.all(th0 == 0.0)


def test_rep105_odometry_twist_in_the_child_frame_is_rotated_into_the_parent():
    """A vehicle's odometry (heading in the orientation, forward speed in twist.linear.x) is read as the
    velocity it is, with its covariance rotated too; the identity and the unset orientation read as before."""
    from track_msgs_py.odometry import yaw_to_quaternion

    heading = math.radians(30.0)  # REP-103 yaw: 30° counter-clockwise from east
    msg = cv_state_to_odometry(5.0, np.array([10.0, 0.0, 20.0, 0.0]), np.diag([1.0, 4.0, 1.0, 0.25]))
    msg.pose.pose.orientation.z, msg.pose.pose.orientation.w = yaw_to_quaternion(heading)
    msg.twist.twist.linear.x = 3.0  # forward
    _, x, P = odometry_to_cv_state(msg)
    np.testing.assert_allclose(x, [10.0, 3.0 * math.cos(heading), 20.0, 3.0 * math.sin(heading)], atol=1e-12)
    c, s = math.cos(heading), math.sin(heading)
    R = np.array([[c, -s], [s, c]])
    np.testing.assert_allclose(P[np.ix_([1, 3], [1, 3])], R @ np.diag([4.0, 0.25]) @ R.T, atol=1e-12)
    for w in (1.0, 0.0):  # identity, and the all-zero quaternion a driver leaves unset
        msg.pose.pose.orientation.z, msg.pose.pose.orientation.w = 0.0, w
        _, x, _ = odometry_to_cv_state(msg)
        assert x[1] == 3.0 and x[3] == 0.0


def test_a_quaternion_that_is_not_unit_is_refused():
    from track_msgs_py.validate import odometry_problem

    msg = cv_state_to_odometry(5.0, np.zeros(4), np.eye(4))
    msg.pose.pose.orientation.w = 2.0
    assert 'not a unit quaternion' in odometry_problem(msg, {'map'})
    msg.pose.pose.orientation.w = 0.0
    assert odometry_problem(msg, {'map'}) is None
    msg.pose.pose.orientation.z = 1e-200  # its square underflows: no rotation to read, refused
    assert 'not a unit quaternion' in odometry_problem(msg, {'map'})
    _, x, _ = odometry_to_cv_state(msg)  # and read without a division by zero
    assert np.all(np.isfinite(x))
