"""Validation returns a one-line reason naming the field, or None for a usable message."""

import numpy as np
import pytest
from rclpy.serialization import deserialize_message, serialize_message

from track_msgs_py.odometry import cv_state_to_odometry, position_to_pose_cov
from track_msgs_py.topics import KNOWN_FRAMES
from track_msgs_py.validate import StampMonotonic, odometry_problem, pose_cov_problem

X = np.array([1.0, 0.5, -2.0, 0.25])
P = np.diag([4.0, 1.0, 9.0, 0.5])
Z = np.array([1.0, 2.0])
R = np.array([[2.0, 0.3], [0.3, 1.0]])


def odom():
    return cv_state_to_odometry(5.0, X, P, 'map', 'track_1')


def pose_cov():
    return position_to_pose_cov(5.0, Z, R, 'map')


def set_cov(msg_cov_owner, entries):
    cov = np.array(msg_cov_owner.covariance)
    for i, v in entries.items():
        cov[i] = v
    msg_cov_owner.covariance = cov


def test_valid_messages_are_accepted_also_after_cdr():
    assert odometry_problem(odom(), KNOWN_FRAMES) is None
    assert pose_cov_problem(pose_cov(), KNOWN_FRAMES) is None
    o = deserialize_message(serialize_message(odom()), type(odom()))
    assert odometry_problem(o, KNOWN_FRAMES) is None


def test_unused_diagonal_entries_still_validate():
    """Our 6×6 covariances (z/roll/pitch 0, yaw 1e6) validate, and so do zero x/y variances for truth."""
    truth = cv_state_to_odometry(0.0, X, np.zeros((4, 4)), 'map', 'truth')
    assert odometry_problem(truth, KNOWN_FRAMES) is None
    msg = pose_cov()
    set_cov(msg.pose, {14: 0.0, 21: 1e12, 35: 1e-12})  # another producer's choice for unused entries
    assert pose_cov_problem(msg, KNOWN_FRAMES) is None


def test_our_estimates_pass_the_input_policy():
    """Issue 19: every covariance our converters write passes the policy of the nodes that read it."""
    from track_msgs_py.covariance import NOT_ESTIMATED_VARIANCE
    from track_msgs_py.odometry import pose_to_odometry
    from track_msgs_py.validate import odometry_bounds_problem, pose_cov_bounds_problem, variance_problem

    idsq = cv_state_to_odometry(1.0, X, np.diag([4.0, NOT_ESTIMATED_VARIANCE, 9.0, NOT_ESTIMATED_VARIANCE]), 'map')
    slam = pose_to_odometry(1.0, np.array([1.0, 2.0, 0.5]), np.diag([0.1, 0.2, 0.01]))
    for msg in (odom(), idsq, slam):
        assert odometry_problem(msg, KNOWN_FRAMES) is None and odometry_bounds_problem(msg) is None
        for cov in (msg.pose.covariance, msg.twist.covariance):  # every diagonal entry 0 or inside the range
            d = np.diag(np.asarray(cov).reshape(6, 6))
            assert np.all((d == 0.0) | ((d >= 1e-12) & (d <= 1e14))), d
        twist_xy = np.asarray(msg.twist.covariance).reshape(6, 6)[:2, :2]
        assert variance_problem('twist.covariance', twist_xy) is None
    assert pose_cov_problem(pose_cov(), KNOWN_FRAMES) is None and pose_cov_bounds_problem(pose_cov()) is None


def test_nan_position():
    msg = odom()
    msg.pose.pose.position.y = float('nan')
    reason = odometry_problem(msg, KNOWN_FRAMES)
    assert reason == 'pose.pose.position: non-finite y=nan'
    msg = pose_cov()
    msg.pose.pose.position.x = float('nan')
    assert pose_cov_problem(msg, KNOWN_FRAMES) == 'pose.pose.position: non-finite x=nan'


def test_inf_velocity():
    msg = odom()
    msg.twist.twist.linear.x = float('inf')
    assert odometry_problem(msg, KNOWN_FRAMES) == 'twist.twist.linear: non-finite x=inf'


@pytest.mark.parametrize(('index', 'field'), [(7, 'pose.covariance'), (35, 'pose.covariance')])
def test_inf_covariance_in_pose_cov(index, field):
    msg = pose_cov()
    set_cov(msg.pose, {index: float('inf')})
    reason = pose_cov_problem(msg, KNOWN_FRAMES)
    assert reason.startswith(f'{field}: ') and 'non-finite' in reason and f'index {index}' in reason


def test_inf_covariance_in_odometry_twist():
    msg = odom()
    set_cov(msg.twist, {0: float('inf')})
    reason = odometry_problem(msg, KNOWN_FRAMES)
    assert reason.startswith('twist.covariance: ') and 'non-finite' in reason


def test_non_symmetric_covariance():
    msg = pose_cov()
    set_cov(msg.pose, {1: 0.3, 6: 0.5})
    reason = pose_cov_problem(msg, KNOWN_FRAMES)
    assert reason.startswith('pose.covariance: ') and 'not symmetric' in reason


def test_negative_eigenvalue_covariance():
    msg = odom()
    set_cov(msg.pose, {0: 1.0, 1: 2.0, 6: 2.0, 7: 1.0})  # eigenvalues 3 and -1
    reason = odometry_problem(msg, KNOWN_FRAMES)
    assert reason == 'pose.covariance: covariance is not positive semi-definite (smallest eigenvalue -1)'
    msg = pose_cov()
    set_cov(msg.pose, {0: -3.0, 1: 0.0, 6: 0.0})
    assert 'not positive semi-definite (smallest eigenvalue -3)' in pose_cov_problem(msg, KNOWN_FRAMES)


def test_unknown_frame():
    msg = position_to_pose_cov(1.0, Z, R, 'odom')
    reason = pose_cov_problem(msg, KNOWN_FRAMES)
    assert reason == "header.frame_id: unknown frame 'odom' (known: map)"
    assert pose_cov_problem(msg, {'map', 'odom'}) is None
    assert odometry_problem(cv_state_to_odometry(0.0, X, P, ''), KNOWN_FRAMES).startswith('header.frame_id')


def test_first_problem_wins_frame_before_values():
    msg = position_to_pose_cov(1.0, Z, R, 'odom')
    msg.pose.pose.position.x = float('nan')
    assert pose_cov_problem(msg, KNOWN_FRAMES).startswith('header.frame_id')


def test_stamps_equal_accepted_decreasing_rejected_per_key():
    s = StampMonotonic()
    assert s.problem('/demo/reports', 1.0) is None
    assert s.problem('/demo/reports', 1.0) is None  # equal stamp accepted
    assert s.problem('/demo/reports', 2.5) is None
    reason = s.problem('/demo/reports', 2.0)
    assert reason is not None and reason.startswith('header.stamp:') and 'before' in reason and '2.5' in reason
    assert s.last('/demo/reports') == 2.5  # the rejected stamp is not remembered
    assert s.problem('track_2', 0.5) is None  # other keys are independent
    assert 'non-finite' in s.problem('/demo/reports', float('nan'))
    s.reset('/demo/reports')
    assert s.problem('/demo/reports', 0.0) is None


def test_stamp_monotonic_reads_message_header():
    s = StampMonotonic()
    assert s.msg_problem('a', odom()) is None
    assert s.msg_problem('a', cv_state_to_odometry(4.999, X, P)) is not None


# --- InputPolicy (issue 13): magnitudes, variances and stamps a finite check lets through -------------

def test_policy_refuses_huge_positions_and_variances_beyond_floor_and_ceiling():
    from geometry_msgs.msg import PoseWithCovarianceStamped

    from track_msgs_py.validate import InputPolicy, pose_cov_bounds_problem

    policy = InputPolicy()

    def msg(x=1.0, var=(4.0, 4.0)):
        m = PoseWithCovarianceStamped()
        m.pose.pose.position.x = x
        m.pose.covariance[0], m.pose.covariance[7] = var
        return m

    assert pose_cov_bounds_problem(msg(), policy) is None
    assert 'beyond the bound' in pose_cov_bounds_problem(msg(x=1e308), policy)
    for var, word in (((0.0, 4.0), 'floor'), ((5e-324, 5e-324), 'floor'), ((1e30, 4.0), 'ceiling')):
        assert word in pose_cov_bounds_problem(msg(var=var), policy), var


def test_stamp_problem_zero_future_and_nonfinite():
    from track_msgs_py.validate import InputPolicy, stamp_problem

    policy = InputPolicy(horizon=10.0)
    assert stamp_problem(5.0, now=0.0, policy=policy) is None
    assert 'zero stamp' in stamp_problem(0.0, now=0.0, policy=policy)
    assert stamp_problem(0.0, now=0.0, policy=policy, required=False) is None
    assert 'ahead of the clock' in stamp_problem(2147483647.0, now=100.0, policy=policy)
    assert 'non-finite' in stamp_problem(float('nan'), now=None)
    assert stamp_problem(1e12, now=None) is None  # no clock: no horizon


def test_clock_now_is_none_while_the_clock_reads_zero():
    from track_msgs_py.validate import clock_now, stamp_problem

    assert clock_now(0) is None and clock_now(1_500_000_000) == 1.5
    assert stamp_problem(2147483647.0, clock_now(0)) is None  # no clock yet: no horizon test
    assert 'ahead of the clock' in stamp_problem(2147483647.0, clock_now(1_700_000_000 * 10**9))
    assert 'zero stamp' in stamp_problem(0.0, clock_now(0))


def test_speed_steer_problem_bounds_the_speed():
    from track_msgs_py.validate import speed_steer_problem

    assert speed_steer_problem(3.0, 0.2) is None and speed_steer_problem(-3.0, -1.5) is None
    for speed in (1e308, -1e30, 2e4, float('nan')):
        assert speed_steer_problem(speed, 0.0).startswith('twist.linear')
    for steer in (1.6, float('inf'), -1e308):
        assert speed_steer_problem(1.0, steer).startswith('twist.angular')


@pytest.mark.parametrize('entry', [1e308, -1e308, 1e15])
def test_variance_problem_refuses_huge_entries_without_overflow(entry):
    """1e308 + 1e308 overflowed to inf in the symmetrisation and the eigenvalue test let it through."""
    import warnings

    from track_msgs_py.validate import variance_problem

    C = np.eye(2)
    C[0, 0] = abs(entry)
    C2 = np.eye(2)
    C2[0, 1] = C2[1, 0] = entry
    with warnings.catch_warnings():
        warnings.simplefilter('error')
        for c in (C, C2, np.full((2, 2), entry)):
            assert 'above the variance ceiling' in variance_problem('pose.covariance', c)
