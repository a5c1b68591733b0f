"""The transform tree: ``/tf`` and ``/tf_static``, their QoS, and transforms of planar poses.

Every frame other than ``map`` that a message names is placed in ``map`` through these two
topics (DESIGN.md, REP-105), so RViz, Foxglove and ``tf2`` draw everything, also from a bag.

- ``TF`` and ``TF_STATIC`` are absolute names, as tf2_ros uses them (a node namespace does not
  move the tree); they are entries of ``topics.TOPICS`` (defined there, re-exported here).
  Type ``tf2_msgs/msg/TFMessage`` (``interfaces/tf2_msgs``, built at install).
- ``TF_QOS``: reliable, volatile, depth 100 (tf2_ros's ``DynamicBroadcasterQoS``).
- ``TF_STATIC_QOS``: reliable, transient-local, KEEP_LAST depth 1 (tf2_ros's
  ``StaticBroadcasterQoS``): each publisher's one message carries ALL its static transforms, so a
  late subscriber (a recorder started later) still gets the whole static set of every publisher.
- ``planar_transform``: a ``TransformStamped`` of a pose (x, y, yaw) of ``child`` in ``parent``,
  after ``frame_pair_problem`` (tf2 rejects empty ids, ids starting with '/', and parent ==
  child). Track ids that travel in ``child_frame_id`` of Odometry follow the same id rules
  (``frame_id_problem``), although they are not frames of the tree (``TRACK_CHILD_NOTE``).
- ``pose_transform`` / ``odometry_transform``: the same for a ``Pose`` (a PoseStamped of a frame,
  the Odometry of a body frame such as the SLAM laser), so the tree and the message agree exactly.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from geometry_msgs.msg import TransformStamped
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from track_msgs_py.stamps import sec_to_stamp
from track_msgs_py.topics import SLAM_POSE, SLAM_TRUTH, SONAR_OBSERVER, TF, TF_STATIC

__all__ = ['BODY_FRAME_TOPICS', 'TF', 'TF_MSGTYPE', 'TF_QOS', 'TF_STATIC', 'TF_STATIC_QOS', 'frame_id_problem',
           'frame_pair_problem',
           'odometry_transform', 'planar_transform', 'pose_transform', 'tf_message']

TF_MSGTYPE = 'tf2_msgs/msg/TFMessage'

TF_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100, reliability=ReliabilityPolicy.RELIABLE,
                    durability=DurabilityPolicy.VOLATILE)
TF_STATIC_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.RELIABLE,
                           durability=DurabilityPolicy.TRANSIENT_LOCAL)

# Odometry topics whose child_frame_id is a body frame placed on /tf (the pose is that frame's);
# on every other Odometry topic the child_frame_id is a track or target id (TRACK_CHILD_NOTE).
BODY_FRAME_TOPICS: frozenset[str] = frozenset({SLAM_POSE, SLAM_TRUTH, SONAR_OBSERVER})

TRACK_CHILD_NOTE = ('child_frame_id of a track or target Odometry names the track, not a frame: tracks are '
                    'not broadcast on /tf (their pose is the message itself)')


def frame_id_problem(frame_id: str, field: str = 'frame_id') -> str | None:
    """Why tf2 would refuse ``frame_id`` (empty, or starting with '/'), else ``None``."""
    if not frame_id:
        return f'{field}: empty frame id'
    if frame_id.startswith('/'):
        return f'{field}: frame id {frame_id!r} starts with "/" (tf2 refuses it)'
    if any(c.isspace() for c in frame_id):
        return f'{field}: frame id {frame_id!r} contains white space'
    return None


def frame_pair_problem(parent: str, child: str) -> str | None:
    """Why tf2 would refuse a transform from ``parent`` to ``child``, else ``None``."""
    problem = frame_id_problem(parent, 'header.frame_id') or frame_id_problem(child, 'child_frame_id')
    if problem is None and parent == child:
        problem = f'child_frame_id: {child!r} equals the parent frame (a transform to itself)'
    return problem


def planar_transform(t: float, parent: str, child: str, x: float, y: float, yaw: float) -> TransformStamped:
    """The pose (x, y, yaw) of ``child`` in ``parent`` at ``t`` [s] as a TransformStamped (z = 0).

    Raises ``ValueError`` for a pair tf2 would refuse or non-finite numbers (a broadcaster's bug,
    never hostile input: nodes broadcast poses they computed).
    """
    problem = frame_pair_problem(parent, child)
    if problem is not None:
        raise ValueError(problem)
    x, y, yaw = float(x), float(y), float(yaw)
    if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(yaw)):
        raise ValueError(f'transform {parent} -> {child}: non-finite pose ({x!r}, {y!r}, {yaw!r})')
    msg = TransformStamped()
    msg.header.stamp, msg.header.frame_id, msg.child_frame_id = sec_to_stamp(t), parent, child
    msg.transform.translation.x, msg.transform.translation.y = x, y
    msg.transform.rotation.z, msg.transform.rotation.w = math.sin(yaw / 2), math.cos(yaw / 2)
    return msg


def pose_transform(header, pose, child: str) -> TransformStamped:
    """The ``geometry_msgs/Pose`` ``pose`` of frame ``child`` in ``header.frame_id`` at ``header.stamp``."""
    problem = frame_pair_problem(header.frame_id, child)
    if problem is not None:
        raise ValueError(problem)
    msg = TransformStamped(child_frame_id=child)
    msg.header.stamp, msg.header.frame_id = header.stamp, header.frame_id
    p, q = pose.position, pose.orientation
    msg.transform.translation.x, msg.transform.translation.y, msg.transform.translation.z = p.x, p.y, p.z
    msg.transform.rotation.x, msg.transform.rotation.y, msg.transform.rotation.z, msg.transform.rotation.w = (
        q.x, q.y, q.z, q.w)
    return msg


def odometry_transform(msg) -> TransformStamped:
    """The pose of a body-frame ``nav_msgs/Odometry`` as the transform header.frame_id → child_frame_id."""
    return pose_transform(msg.header, msg.pose.pose, msg.child_frame_id)


def tf_message(transforms: Sequence[TransformStamped]):
    """A ``tf2_msgs/TFMessage`` carrying ``transforms``."""
    from tf2_msgs.msg import TFMessage

    return TFMessage(transforms=list(transforms))
