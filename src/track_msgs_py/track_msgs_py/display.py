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
"""

from __future__ import annotations

import numpy as np
from sensor_msgs.msg import PointField

from track_msgs_py.clouds import XYZ

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
