"""Validation of incoming messages that returns a reason instead of raising.

The checks run before a filter sees the message and return one line naming the field
(``"pose.covariance: covariance is not positive semi-definite (smallest eigenvalue -3)"``), or
``None`` when the message is usable. The node logs the reason, counts the drop and goes on.

What is checked (the fields ``track_msgs_py.odometry`` reads):
- ``header.frame_id`` in the caller's known frames; ``header.stamp.nanosec`` < 1e9;
- every number read finite (positions, orientation, velocities, all 36 covariance entries);
- the x/y covariance blocks symmetric PSD (``track_core.filters.gaussian.covariance_problem``);
  the other diagonal entries are not read;
- stamps not backwards per key (``StampMonotonic``); equal stamps accepted.

``InputPolicy`` adds what finite-ness alone lets through:
- positions and ranges within ``world_bound`` m, speeds within ``speed_bound`` m/s;
- the x/y block positive definite, both eigenvalues in [``variance_floor``, ``variance_ceiling``] m²;
- stamps not zero where required, not over ``horizon`` s ahead of the node clock
  (``stamp_problem``); a refused stamp never moves a watermark;
- ``lead``: a node with a stamp watermark refuses a stamp over ``lead`` s ahead (refused, not held:
  one fast clock would otherwise blank every honest report after it for up to ``horizon`` s).
Watermarks and the node clock go back together after a clock jump
(``track_nodes.base.timejump``): ``reset`` forgets them.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Hashable
from dataclasses import dataclass

import numpy as np

from track_core.filters.gaussian import covariance_problem
from track_msgs_py.covariance import xy_block
from track_msgs_py.stamps import stamp_to_sec


@dataclass(frozen=True)
class InputPolicy:
    """Bounds a usable message respects (SI units; defaults generous for any scenario here)."""

    horizon: float = 60.0  # a stamp may be at most this far ahead of the node's clock [s]
    world_bound: float = 1e7  # |position|, |range| [m] (beyond the Earth's diameter)
    speed_bound: float = 1e4  # |velocity| [m/s]
    variance_floor: float = 1e-12  # smallest eigenvalue of a position covariance [m²]
    variance_ceiling: float = 1e14  # largest eigenvalue of a position covariance [m²]
    lead: float | None = None  # look-ahead tolerance: refuse stamps more than this ahead of the clock [s]

    def __post_init__(self) -> None:
        if not (self.horizon > 0 and self.world_bound > 0 and self.speed_bound > 0
                and 0 < self.variance_floor < self.variance_ceiling
                and (self.lead is None or self.lead > 0)):
            raise ValueError(f'invalid input policy {self}')


DEFAULT_POLICY = InputPolicy()


def bound_problem(field: str, bound: float, **values: float) -> str | None:
    """Reason naming the first value that is non-finite or beyond ``±bound``."""
    for name, value in values.items():
        if not math.isfinite(value):
            return f'{field}: non-finite {name}={value}'
        if abs(value) > bound:
            return f'{field}: {name}={value:g} is beyond the bound ±{bound:g}'
    return None


def variance_problem(field: str, C: np.ndarray, policy: InputPolicy = DEFAULT_POLICY) -> str | None:
    """Reason when the symmetric block ``C`` is not a covariance with eigenvalues in the policy's range."""
    C = np.asarray(C, dtype=float)
    if not np.all(np.isfinite(C)):
        return f'{field}: covariance has non-finite entries'
    if C.size and np.max(np.abs(C)) > policy.variance_ceiling:  # before any sum: 1e308 + 1e308 overflows
        return f'{field}: entry {np.max(np.abs(C)):.3g} is above the variance ceiling {policy.variance_ceiling:g}'
    reason = covariance_problem(C)
    if reason is not None:
        return f'{field}: {reason}'
    eig = np.linalg.eigvalsh(0.5 * (C + C.T))
    if eig[0] < policy.variance_floor:
        return f'{field}: smallest variance {eig[0]:.3g} is below the floor {policy.variance_floor:g}'
    if eig[-1] > policy.variance_ceiling:
        return f'{field}: largest variance {eig[-1]:.3g} is above the ceiling {policy.variance_ceiling:g}'
    return None


def stamp_problem(t: float, now: float | None, policy: InputPolicy = DEFAULT_POLICY, *,
                  required: bool = True, field: str = 'header.stamp') -> str | None:
    """Reason when stamp ``t`` [s] is zero (if ``required``), non-finite, or beyond the horizon (or lead) of ``now``.

    ``now`` is the receiving node's clock [s]; ``None`` skips the horizon test (a node without a clock).
    """
    if not math.isfinite(t):
        return f'{field}: non-finite stamp {t}'
    if required and t == 0.0:
        return f'{field}: zero stamp (a time is required)'
    if now is not None and t > now + policy.horizon:
        return f'{field}: {t:.9g} s is {t - now:.3g} s ahead of the clock ({now:.9g} s; horizon {policy.horizon:g} s)'
    if now is not None and policy.lead is not None and t > now + policy.lead:
        return (f'{field}: {t:.9g} s is {t - now:.3g} s ahead of the clock ({now:.9g} s; look-ahead tolerance '
                f'{policy.lead:g} s: a source with a fast clock?)')
    return None


def pose_cov_bounds_problem(msg, policy: InputPolicy = DEFAULT_POLICY) -> str | None:
    """Policy checks of a ``PoseWithCovarianceStamped`` beyond ``pose_cov_problem``: position bound, variances."""
    p = msg.pose.pose.position
    return (bound_problem('pose.pose.position', policy.world_bound, x=p.x, y=p.y, z=p.z)
            or variance_problem('pose.covariance', xy_block(np.asarray(msg.pose.covariance, float)), policy))


def odometry_bounds_problem(msg, policy: InputPolicy = DEFAULT_POLICY, *, pose_covariance: bool = True) -> str | None:
    """Policy checks of an ``Odometry``: position and velocity bounds, and (optionally) the x/y variances."""
    p, v = msg.pose.pose.position, msg.twist.twist.linear
    return (bound_problem('pose.pose.position', policy.world_bound, x=p.x, y=p.y, z=p.z)
            or bound_problem('twist.twist.linear', policy.speed_bound, x=v.x, y=v.y, z=v.z)
            or (variance_problem('pose.covariance', xy_block(np.asarray(msg.pose.covariance, float)), policy)
                if pose_covariance else None))


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


QUATERNION_NORM_TOL = 1e-3  # |‖q‖ − 1| allowed: float32 round trips and drivers that normalise loosely


def quaternion_problem(field: str, q) -> str | None:
    """Reason naming the first non-finite component of a Quaternion, or a norm that is not 1 (the all-zero
    quaternion, an orientation left unset, is accepted and read as the identity)."""
    reason = finite_problem(field, x=q.x, y=q.y, z=q.z, w=q.w)
    if reason:
        return reason
    if q.x == 0.0 and q.y == 0.0 and q.z == 0.0 and q.w == 0.0:
        return None
    norm = math.sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w)
    if not abs(norm - 1.0) <= QUATERNION_NORM_TOL:
        return f'{field}: not a unit quaternion (norm {norm:.6g})'
    return None


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


def clock_now(nanoseconds: int) -> float | None:
    """The receiving node's clock [s] for ``stamp_problem``'s horizon, or ``None`` while it reads zero.

    Under ``use_sim_time`` a node's clock is 0 until its first ``/clock`` message. Measuring the
    horizon from 0 would refuse every stamp of a replayed bag (epoch times) until then, and for
    good if no ``/clock`` ever comes, so while the clock reads zero the horizon test is skipped
    (zero and non-finite stamps are still refused). A far-future stamp arriving in that window
    alone is not caught; from the first ``/clock`` on every one is.
    """
    return nanoseconds * 1e-9 if nanoseconds > 0 else None


def speed_steer_problem(speed: float, steer: float, policy: InputPolicy = DEFAULT_POLICY) -> str | None:
    """Reason a vehicle input (``twist.linear.x`` speed [m/s], ``twist.angular.z`` steering [rad]) is unusable."""
    reason = bound_problem('twist.linear', policy.speed_bound, x=speed)
    if reason is None and not (math.isfinite(steer) and abs(steer) < math.pi / 2):
        reason = f'twist.angular: steering z={steer} (need a finite |steering| < π/2)'
    return reason
