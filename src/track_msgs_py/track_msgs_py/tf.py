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
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from geometry_msgs.msg import TransformStamped
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from track_msgs_py.convert import sec_to_stamp
from track_msgs_py.topics import TF, TF_STATIC

__all__ = ['TF', 'TF_MSGTYPE', 'TF_QOS', 'TF_STATIC', 'TF_STATIC_QOS', 'frame_id_problem', 'frame_pair_problem',
           'planar_transform', 'tf_message']

TF_MSGTYPE = 'tf2_msgs/msg/TFMessage'

TF_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100, reliability=ReliabilityPolicy.RELIABLE,
                    durability=DurabilityPolicy.VOLATILE)
TF_STATIC_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.RELIABLE,
                           durability=DurabilityPolicy.TRANSIENT_LOCAL)

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


def tf_message(transforms: Sequence[TransformStamped]):
    """A ``tf2_msgs/TFMessage`` carrying ``transforms``."""
    from tf2_msgs.msg import TFMessage

    return TFMessage(transforms=list(transforms))
