"""Tracks, reports and poses ⇄ ``Odometry``, ``PoseWithCovarianceStamped``, ``PoseArray`` and ``TwistStamped``.

Covariances are the planar 6×6 of ``track_msgs_py.covariance``.

- CV state ``x=[x,ẋ,y,ẏ]``, ``P`` (4×4) ⇄ nav_msgs/Odometry: ``header.frame_id`` ``map``,
  ``child_frame_id`` the track id; ``pose.pose.position.x/y`` ← x, y (z = 0), orientation identity;
  ``twist.twist.linear.x/y`` ← ẋ, ẏ (angular 0); ``pose.covariance`` x/y block ← P[[0,2],[0,2]],
  ``twist.covariance`` x/y block ← P[[1,3],[1,3]]; z/roll/pitch ``PLANAR_VARIANCE`` (0), yaw and yaw
  rate ``NOT_ESTIMATED_VARIANCE``.
- Position report ``z`` (2,), ``R`` (2×2) ⇄ PoseWithCovarianceStamped: position ← z (z = 0),
  orientation identity, x/y block ← R, z/roll/pitch 0, yaw not estimated.
- Particle positions (N, 2) and headings → PoseArray: ``poses[i].position.x/y`` (z = 0), the heading
  about z (identity without one). No weights: publish clouds after resampling.
- The SLAM laser pose (``pose_to_odometry``) and inputs (``inputs_to_twist``): see ``topics``.

Deviations: Odometry twist is in ``child_frame_id`` (REP-105); our tracks carry no heading, so the
child frame is axis-aligned with ``map`` and the twist is the map-frame velocity. On the way in
``odometry_to_cv_state`` rotates the twist (and its covariance) by the pose's orientation into
``header.frame_id`` (an identity or all-zero orientation rotates nothing, bit for bit).
Position–velocity cross-covariances have no slot: dropped on the way out, zero on the way in.
"""

from __future__ import annotations

import math

import numpy as np
from geometry_msgs.msg import Point, Pose, PoseArray, PoseWithCovarianceStamped, TwistStamped
from nav_msgs.msg import Odometry

from track_msgs_py.covariance import NOT_ESTIMATED_VARIANCE, as_shape, planar_covariance, xy_block
from track_msgs_py.stamps import stamp_to_sec, stamped_header
from track_msgs_py.topics import FRAME_BASE, FRAME_LASER, FRAME_MAP

_POS = [0, 2]  # indices of x, y in the CV state [x, ẋ, y, ẏ]
_VEL = [1, 3]  # indices of ẋ, ẏ


# --- CV state ⇄ Odometry --------------------------------------------------------------------

def cv_state_to_odometry(t: float, x: np.ndarray, P: np.ndarray, frame_id: str = FRAME_MAP,
                         child_frame_id: str = '') -> Odometry:
    """CV state ``x=[x, ẋ, y, ẏ]`` with covariance ``P`` (4×4) at ``t`` → ``nav_msgs/Odometry``.

    See the module table; position–velocity cross-covariances are dropped.
    """
    x = as_shape(x, (4,), 'x')
    P = as_shape(P, (4, 4), 'P')
    msg = Odometry(header=stamped_header(t, frame_id), child_frame_id=child_frame_id)
    msg.pose.pose.position.x, msg.pose.pose.position.y = float(x[0]), float(x[2])
    msg.pose.pose.orientation.w = 1.0
    msg.twist.twist.linear.x, msg.twist.twist.linear.y = float(x[1]), float(x[3])
    msg.pose.covariance = planar_covariance(P[0::2, 0::2])   # rows/columns _POS = [0, 2] (a slice: no fancy index)
    msg.twist.covariance = planar_covariance(P[1::2, 1::2])  # _VEL = [1, 3]
    return msg


def odometry_to_cv_state(msg: Odometry) -> tuple[float, np.ndarray, np.ndarray]:
    """``nav_msgs/Odometry`` → ``(t, x=[x, ẋ, y, ẏ], P)`` in ``header.frame_id``; P's position–velocity
    blocks are zero. The twist is in ``child_frame_id`` (REP-105) and is rotated by the pose's
    orientation (``orientation_matrix``) into the parent frame, with its covariance."""
    p, v = msg.pose.pose.position, msg.twist.twist.linear
    R = orientation_matrix(msg.pose.pose.orientation)
    if R is None:  # identity: the twist is already in the parent frame
        vx, vy = v.x, v.y
        vel_cov = xy_block(msg.twist.covariance)
    else:
        vx, vy, _ = R @ np.array([v.x, v.y, v.z], dtype=float)
        lin = np.asarray(msg.twist.covariance, dtype=float).reshape(6, 6)[:3, :3]
        vel_cov = (R @ lin @ R.T)[:2, :2]
    x = np.array([p.x, vx, p.y, vy], dtype=float)
    P = np.zeros((4, 4))
    P[np.ix_(_POS, _POS)] = xy_block(msg.pose.covariance)
    P[np.ix_(_VEL, _VEL)] = vel_cov
    return stamp_to_sec(msg.header.stamp), x, P


def orientation_matrix(q) -> np.ndarray | None:
    """Rotation matrix (3×3) of a ``geometry_msgs/Quaternion``, normalised; ``None`` for the identity and for
    the unset all-zero quaternion (which many drivers leave in a message without an orientation)."""
    x, y, z, w = float(q.x), float(q.y), float(q.z), float(q.w)
    n = x * x + y * y + z * z + w * w
    if (x == 0.0 and y == 0.0 and z == 0.0) or not n > 0.0:  # identity, unset, or too small to mean a rotation
        return None
    return quaternion_matrix(x, y, z, w)


def quaternion_matrix(x: float, y: float, z: float, w: float) -> np.ndarray:
    """Rotation matrix (3×3) of the quaternion (x, y, z, w), normalised on the way (a non-zero one)."""
    s = 2.0 / (x * x + y * y + z * z + w * w)
    return np.array([
        [1.0 - s * (y * y + z * z), s * (x * y - z * w), s * (x * z + y * w)],
        [s * (x * y + z * w), 1.0 - s * (x * x + z * z), s * (y * z - x * w)],
        [s * (x * z - y * w), s * (y * z + x * w), 1.0 - s * (x * x + y * y)],
    ])


def yaw_to_quaternion(yaw: float) -> tuple[float, float]:
    """(z, w) of the rotation by ``yaw`` [rad] about the z axis (REP-103: counter-clockwise from x)."""
    return math.sin(0.5 * yaw), math.cos(0.5 * yaw)


# --- position report ⇄ PoseWithCovarianceStamped --------------------------------------------

def position_to_pose_cov(t: float, z: np.ndarray, R: np.ndarray,
                         frame_id: str = FRAME_MAP) -> PoseWithCovarianceStamped:
    """Position ``z`` (2,) with covariance ``R`` (2×2) → ``geometry_msgs/PoseWithCovarianceStamped``."""
    z = as_shape(z, (2,), 'z')
    R = as_shape(R, (2, 2), 'R')
    msg = PoseWithCovarianceStamped(header=stamped_header(t, frame_id))
    msg.pose.pose.position.x, msg.pose.pose.position.y = float(z[0]), float(z[1])
    msg.pose.pose.orientation.w = 1.0
    msg.pose.covariance = planar_covariance(R)
    return msg


def pose_cov_to_position(msg: PoseWithCovarianceStamped) -> tuple[float, np.ndarray, np.ndarray]:
    """``geometry_msgs/PoseWithCovarianceStamped`` → ``(t, z (2,), R (2×2))``."""
    p = msg.pose.pose.position
    return stamp_to_sec(msg.header.stamp), np.array([p.x, p.y], dtype=float), xy_block(msg.pose.covariance)


# --- particle positions ⇄ PoseArray ---------------------------------------------------------

def positions_to_pose_array(t: float, xy: np.ndarray, frame_id: str = FRAME_MAP,
                            headings: np.ndarray | None = None) -> PoseArray:
    """(N, 2) particle positions (and optional headings, rad from +x) → PoseArray (z = 0).

    Particle clouds are for display, so weights are not carried: publish after resampling.
    """
    xy = np.asarray(xy, dtype=float)
    msg = PoseArray()
    msg.header = stamped_header(t, frame_id)
    half = np.zeros(len(xy)) if headings is None else 0.5 * np.asarray(headings, dtype=float)
    msg.poses = [Pose(position=Point(x=px, y=py)) for px, py in xy.tolist()]
    for pose, qz, qw in zip(msg.poses, np.sin(half).tolist(), np.cos(half).tolist(), strict=True):
        pose.orientation.z, pose.orientation.w = qz, qw
    return msg


def pose_array_to_positions(msg: PoseArray) -> tuple[np.ndarray, np.ndarray]:
    """Inverse of :func:`positions_to_pose_array`: ((N, 2) positions, (N,) headings)."""
    xy = np.array([(p.position.x, p.position.y) for p in msg.poses], dtype=float).reshape(-1, 2)
    q = np.array([(p.orientation.z, p.orientation.w) for p in msg.poses], dtype=float).reshape(-1, 2)
    return xy, 2.0 * np.arctan2(q[:, 0], q[:, 1])


# --- SLAM pose ⇄ Odometry, inputs ⇄ TwistStamped (the topics are in track_msgs_py.topics) ----

_POSE_IDX = (0, 1, 5)  # x, y, yaw in the 6×6 row-major pose covariance of Odometry


def pose_to_odometry(t: float, pose: np.ndarray, P: np.ndarray, frame_id: str = FRAME_MAP,
                     child_frame_id: str = FRAME_LASER) -> Odometry:
    """Pose (x, y, φ) with covariance P (3×3) → Odometry: orientation yaw φ, covariance entries
    (x, y, yaw) = P, z/roll/pitch ``PLANAR_VARIANCE``; the twist is not estimated (x/y and yaw rate
    ``NOT_ESTIMATED_VARIANCE``, the planar rates 0)."""
    pose = np.asarray(pose, dtype=float)
    msg = Odometry(header=stamped_header(t, frame_id), child_frame_id=child_frame_id)
    msg.pose.pose.position.x, msg.pose.pose.position.y = float(pose[0]), float(pose[1])
    msg.pose.pose.orientation.z, msg.pose.pose.orientation.w = math.sin(pose[2] / 2), math.cos(pose[2] / 2)
    cov = planar_covariance(np.zeros((2, 2)), 0.0).reshape(6, 6)
    cov[np.ix_(_POSE_IDX, _POSE_IDX)] = np.asarray(P, dtype=float)
    msg.pose.covariance = cov.reshape(36)
    msg.twist.covariance = planar_covariance(np.eye(2) * NOT_ESTIMATED_VARIANCE)
    return msg


def quaternion_yaw(q) -> float:
    """Yaw [rad, REP-103] of a ``geometry_msgs/Quaternion``: the rotation about z (ZYX order)."""
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def odometry_to_pose(msg: Odometry) -> tuple[float, np.ndarray, np.ndarray]:
    """Inverse of :func:`pose_to_odometry`: (t, pose (x, y, yaw), P (3×3)); yaw from a z-axis rotation."""
    p = msg.pose.pose.position
    yaw = quaternion_yaw(msg.pose.pose.orientation)
    cov = np.asarray(msg.pose.covariance, dtype=float).reshape(6, 6)[np.ix_(_POSE_IDX, _POSE_IDX)]
    return stamp_to_sec(msg.header.stamp), np.array([p.x, p.y, yaw]), cov.copy()


def inputs_to_twist(t: float, speed: float, steer: float, frame_id: str = FRAME_BASE) -> TwistStamped:
    """Encoder speed [m/s] and steering angle [rad] → TwistStamped (linear.x, angular.z)."""
    msg = TwistStamped(header=stamped_header(t, frame_id))
    msg.twist.linear.x, msg.twist.angular.z = float(speed), float(steer)
    return msg


def twist_to_inputs(msg: TwistStamped) -> tuple[float, float, float]:
    """TwistStamped → (t, encoder speed, steering angle)."""
    return stamp_to_sec(msg.header.stamp), float(msg.twist.linear.x), float(msg.twist.angular.z)
