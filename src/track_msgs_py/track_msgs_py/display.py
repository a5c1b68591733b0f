"""What RViz and Foxglove need of the messages we publish: checks that return a reason.

Not input validation (``track_msgs_py.validate`` judges what a node receives): these check that
our own output follows the display conventions of ``track_msgs_py.clouds``,
``track_msgs_py.covariance`` and the topics table, so a viewer draws it as meant.
``track_nodes.bag.check`` runs them over every message of a bag.

- a ``sensor_msgs/PointCloud2`` carries float32 ``x``, ``y``, ``z`` (count 1) at offsets 0, 4, 8
  (Foxglove refuses a cloud with fewer than two of them, RViz's PointCloud2 display needs all
  three; ``cloud_xyz_problem``);
- a covariance (``pose.covariance`` and ``twist.covariance`` of Odometry, PoseWithCovariance[Stamped],
  TwistWithCovariance[Stamped]) has no z variance larger than its x or y variance, so the
  position ellipse is drawn flat, not as a column (``planar_covariance_problem``). The former
  1e6 on z fails it; the planar 0 passes with any x/y block, truth's zeros included.

Display twins (``display_twin``; the topics: ``topics.DISPLAY_TWINS``): Foxglove's 3D panel draws
neither ``nav_msgs/Odometry`` nor ``geometry_msgs/PointStamped`` (``FOXGLOVE_3D_TYPES``), so a
node publishing one of the topics the layouts draw also publishes its twin on ``<topic>/pose``: an Odometry's
``PoseWithCovarianceStamped`` (same header, pose and covariance: the 2σ ellipse draws), a
PointStamped's ``PoseStamped`` (the point, identity orientation). ``TrackNode.create_publisher``
makes the twin publisher; RViz draws the originals.
"""

from __future__ import annotations

import numpy as np
from sensor_msgs.msg import PointField

from track_msgs_py.clouds import XYZ

#: The ROS 2 message types Foxglove's 3D panel draws. From the 3D panel's documentation ("Supported
#: messages": docs.foxglove.dev/docs/visualization/panels/3d) and its source, the last open release of
#: Foxglove Studio (packages/studio-base/src/panels/ThreeDeeRender/ros.ts: the *_DATATYPES sets its scene
#: extensions subscribe with; each ROS 1 name also in its ``pkg/msg/Type`` form). Neither
#: ``nav_msgs/msg/Odometry`` nor ``geometry_msgs/msg/PointStamped`` is among them: a 3D entry of those
#: types draws nothing, hence the display twins below. (Foxglove's own ``foxglove_msgs`` schemas,
#: SceneUpdate, PoseInFrame and the like, draw too; we publish none.)
FOXGLOVE_3D_TYPES = frozenset({
    'tf2_msgs/msg/TFMessage', 'geometry_msgs/msg/TransformStamped',
    'visualization_msgs/msg/Marker', 'visualization_msgs/msg/MarkerArray',
    'nav_msgs/msg/OccupancyGrid', 'nav_msgs/msg/Path',
    'sensor_msgs/msg/PointCloud2', 'sensor_msgs/msg/LaserScan',
    'geometry_msgs/msg/PoseStamped', 'geometry_msgs/msg/PoseWithCovarianceStamped', 'geometry_msgs/msg/PoseArray',
    'geometry_msgs/msg/PolygonStamped',
    'sensor_msgs/msg/CameraInfo', 'sensor_msgs/msg/Image', 'sensor_msgs/msg/CompressedImage',
})

_XYZ_OFFSETS = (0, 4, 8)


def cloud_xyz_problem(msg) -> str | None:
    """Reason a ``PointCloud2`` lacks float32 x, y, z (count 1) at offsets 0, 4, 8, else ``None``."""
    fields = {f.name: f for f in msg.fields}
    for name, offset in zip(XYZ, _XYZ_OFFSETS, strict=True):
        f = fields.get(name)
        if f is None:
            return f'fields: no {name} (fields: {", ".join(fields) or "none"}; need float32 x, y, z first)'
        if f.datatype != PointField.FLOAT32 or f.count != 1:
            return f'field {name}: datatype {f.datatype}, count {f.count} (need FLOAT32, count 1)'
        if f.offset != offset:
            return f'field {name}: offset {f.offset} (need {offset})'
    return None


def planar_covariance_problem(field: str, covariance) -> str | None:
    """Reason when a 36-entry covariance's z variance is larger than its x or y variance, else ``None``."""
    c = np.asarray(covariance, dtype=float)
    if c.size != 36:
        return f'{field}: expected 36 entries, got {c.size}'
    vx, vy, vz = c[0], c[7], c[14]
    if not vz <= min(vx, vy):  # also refuses a NaN
        return f'{field}: z variance {vz:g} is larger than the x/y variances ({vx:g}, {vy:g}): drawn as a column'
    return None


def _covariances(msg) -> list[tuple[str, object]]:
    """(field path, 36 entries) of every covariance ``msg`` holds at ``pose``/``twist`` (one level down, or the
    message itself for a PoseWithCovariance / TwistWithCovariance)."""
    out = [('covariance', msg.covariance)] if hasattr(msg, 'covariance') else []
    for holder in ('pose', 'twist'):
        inner = getattr(msg, holder, None)
        if inner is not None and hasattr(inner, 'covariance'):
            out.append((f'{holder}.covariance', inner.covariance))
    return out


def display_twin(msg):
    """The drawable twin of an ``Odometry`` (→ ``PoseWithCovarianceStamped``) or a ``PointStamped``
    (→ ``PoseStamped``)."""
    from geometry_msgs.msg import PoseStamped, PoseWithCovarianceStamped

    if hasattr(msg, 'child_frame_id'):  # Odometry
        return PoseWithCovarianceStamped(header=msg.header, pose=msg.pose)
    twin = PoseStamped(header=msg.header)
    twin.pose.position = msg.point
    return twin


def display_problems(msg) -> list[str]:
    """Every reason ``msg`` breaks a display convention (clouds: x, y, z; covariances: planar); ``[]`` if none."""
    out = []
    if type(msg).__name__ == 'PointCloud2':
        reason = cloud_xyz_problem(msg)
        if reason is not None:
            out.append(reason)
    for field, cov in _covariances(msg):
        reason = planar_covariance_problem(field, cov)
        if reason is not None:
            out.append(reason)
    return out
