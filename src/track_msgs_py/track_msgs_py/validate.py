"""Validation of incoming messages that returns a reason instead of raising.

A callback that raises deep inside a filter loses the message and says little; these checks
run first and return one line naming the field (``"pose.covariance: covariance is not positive
semi-definite (smallest eigenvalue -3)"``), or ``None`` when the message is usable. The node
logs the reason, counts the drop and goes on.

What is checked (the fields ``convert`` reads, see its table):

- ``header.frame_id`` is in the caller's set of known frames; ``header.stamp.nanosec`` < 1e9;
- every number read is finite (positions, orientation, velocities, all 36 covariance entries);
- the x/y covariance blocks are symmetric and positive semi-definite, by
  ``track_core.filters.gaussian.covariance_problem``. Only those blocks: the other diagonal
  entries carry ``UNUSED_VARIANCE`` (or whatever another producer wrote) and are not read;
- stamps do not go backwards per key (``StampMonotonic``); equal stamps are accepted.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Hashable

import numpy as np

from track_core.filters.gaussian import covariance_problem
from track_msgs_py.convert import stamp_to_sec, xy_block


def frame_problem(frame_id: str, known_frames: Collection[str] | None, field: str = 'header.frame_id') -> str | None:
    """Reason when ``frame_id`` is not in ``known_frames`` (``None`` skips the check)."""
    if known_frames is None or frame_id in known_frames:
        return None
    return f'{field}: unknown frame {frame_id!r} (known: {", ".join(sorted(known_frames))})'


def header_problem(header, known_frames: Collection[str] | None) -> str | None:
    """Reason when the header's frame is unknown or its stamp is malformed."""
    if not 0 <= header.stamp.nanosec < 1_000_000_000:
        return f'header.stamp.nanosec: {header.stamp.nanosec} is not in [0, 1e9)'
    return frame_problem(header.frame_id, known_frames)


def finite_problem(field: str, **values: float) -> str | None:
    """Reason naming the first non-finite value, e.g. ``pose.pose.position: non-finite x=nan``."""
    for name, value in values.items():
        if not math.isfinite(value):
            return f'{field}: non-finite {name}={value}'
    return None


def xyz_problem(field: str, v) -> str | None:
    """Reason naming the first non-finite component of a Point or Vector3."""
    return finite_problem(field, x=v.x, y=v.y, z=v.z)


def quaternion_problem(field: str, q) -> str | None:
    """Reason naming the first non-finite component of a Quaternion."""
    return finite_problem(field, x=q.x, y=q.y, z=q.z, w=q.w)


def covariance36_problem(field: str, covariance) -> str | None:
    """Reason when a 6×6 row-major covariance is not 36 finite numbers, or its x/y block is not a covariance."""
    c = np.asarray(covariance, dtype=float)
    if c.shape != (36,):
        return f'{field}: expected 36 entries, got shape {c.shape}'
    if not np.all(np.isfinite(c)):
        return f'{field}: covariance has non-finite entries (at index {int(np.flatnonzero(~np.isfinite(c))[0])})'
    reason = covariance_problem(xy_block(c))
    return None if reason is None else f'{field}: {reason}'


def pose_cov_problem(msg, known_frames: Collection[str] | None) -> str | None:
    """Reason a ``geometry_msgs/PoseWithCovarianceStamped`` is unusable, or ``None``."""
    pose = msg.pose
    return (header_problem(msg.header, known_frames)
            or xyz_problem('pose.pose.position', pose.pose.position)
            or quaternion_problem('pose.pose.orientation', pose.pose.orientation)
            or covariance36_problem('pose.covariance', pose.covariance))


def odometry_problem(msg, known_frames: Collection[str] | None) -> str | None:
    """Reason a ``nav_msgs/Odometry`` is unusable, or ``None``. ``child_frame_id`` (a track id) is not checked."""
    pose, twist = msg.pose, msg.twist
    return (header_problem(msg.header, known_frames)
            or xyz_problem('pose.pose.position', pose.pose.position)
            or quaternion_problem('pose.pose.orientation', pose.pose.orientation)
            or xyz_problem('twist.twist.linear', twist.twist.linear)
            or xyz_problem('twist.twist.angular', twist.twist.angular)
            or covariance36_problem('pose.covariance', pose.covariance)
            or covariance36_problem('twist.covariance', twist.covariance))


class StampMonotonic:
    """Last accepted stamp per key (topic, child frame, ...): rejects stamps that go backwards.

    Equal stamps are accepted (two reports of one scan). A rejected stamp is not remembered.
    Call ``reset`` when time legitimately jumps back (a player restarting a bag).
    """

    def __init__(self) -> None:
        self._last: dict[Hashable, float] = {}

    def problem(self, key: Hashable, t: float) -> str | None:
        """Reason when ``t`` is non-finite or before the last accepted stamp of ``key``; else remember ``t``."""
        t = float(t)
        if not math.isfinite(t):
            return f'header.stamp: non-finite stamp {t} s for {key!r}'
        last = self._last.get(key)
        if last is not None and t < last:
            return f'header.stamp: {t!r} s is before the previous stamp {last!r} s for {key!r} (time went backwards)'
        self._last[key] = t
        return None

    def msg_problem(self, key: Hashable, msg) -> str | None:
        """``problem`` with the stamp of ``msg.header``."""
        return self.problem(key, stamp_to_sec(msg.header.stamp))

    def last(self, key: Hashable) -> float | None:
        return self._last.get(key)

    def reset(self, key: Hashable | None = None) -> None:
        """Forget ``key``'s last stamp, or every key's when ``key`` is None."""
        if key is None:
            self._last.clear()
        else:
            self._last.pop(key, None)
