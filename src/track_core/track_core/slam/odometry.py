"""Motion from wheel odometry for the unicycle input model, and the odom frame of REP-105.

Why. A robot's driver publishes ``nav_msgs/Odometry`` (the pose of ``base_link`` in ``odom``, its
twist in ``base_link``) and broadcasts odom → base_link; a localiser publishes map → odom, so that
map → odom → base_link places the robot where the estimate says, and ``base_link`` keeps one parent
(REP-105; slam_toolbox, robot_localization). The filter (``hybrid.HybridSlam``) takes inputs held
from their stamp on (zero-order hold), with the unicycle model of ``models.UnicycleParams``:
u = (v, ω) of base_link. This module turns odometry messages into such inputs, keeps the odom
pose of base_link over time and composes map → odom. Planar poses are (x, y, yaw).

Inputs from odometry (``OdometryInputs``), two ways:

- ``'twist'``: each message's twist (v = linear.x, ω = angular.z in ``child_frame_id``, REP-105) is
  the input from its stamp on;
- ``'increments'``: the motion between two consecutive messages, read from their poses, is the
  unicycle arc that joins them: with the increment (dx, dy, dψ) in the frame of the first pose,
  ω = dψ/Δt and v = s/Δt, s = (dx cos(dψ/2) + dy sin(dψ/2))·(dψ/2)/sin(dψ/2), the arc length of
  the chord projected on the mid-heading (exact for an arc; a sideways slip, which a unicycle
  cannot make, is dropped and returned as ``lateral``). That input is stamped at the *first*
  message, so a stamp-ordered filter applies it over exactly the interval it describes; it is
  released one message late.

Input noise: the twist covariance of the message that starts the hold (entries v, ω = 0 and 5 of
the 6×6; ``track_msgs_py`` reads them), or the filter's parameters.

The odom pose at a time (``OdomTrack``): linear interpolation between the recorded odom poses
(shortest-angle for yaw); after the last one, the last twist's arc. An ACFR car, whose inputs are
raw encoder speed and steering, has no driver odometry: its odom pose is dead-reckoned here from
the inputs (``acfr_to_unicycle``: the twist of the rear-axle centre), as its driver would.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from track_core.filters import wrap_angle

MOTIONS = ('increments', 'twist')


def _sinc_half(dpsi: np.ndarray) -> np.ndarray:
    """(dψ/2)/sin(dψ/2), 1 at dψ = 0 (np.sinc is sin(πx)/(πx))."""
    return 1.0 / np.sinc(np.asarray(dpsi, dtype=float) / (2.0 * np.pi))


def relative_pose(p0: np.ndarray, p1: np.ndarray) -> np.ndarray:
    """The pose p1 (..., 3) in the frame of p0 (..., 3): (dx, dy, dψ), dψ wrapped to (−π, π]."""
    p0, p1 = np.asarray(p0, dtype=float), np.asarray(p1, dtype=float)
    c, s = np.cos(p0[..., 2]), np.sin(p0[..., 2])
    ex, ey = p1[..., 0] - p0[..., 0], p1[..., 1] - p0[..., 1]
    return np.stack([c * ex + s * ey, -s * ex + c * ey, wrap_angle(p1[..., 2] - p0[..., 2])], axis=-1)


def compose(p: np.ndarray, d: np.ndarray) -> np.ndarray:
    """p ⊕ d: the pose d (..., 3), given in the frame of p (..., 3), in p's parent frame."""
    p, d = np.asarray(p, dtype=float), np.asarray(d, dtype=float)
    c, s = np.cos(p[..., 2]), np.sin(p[..., 2])
    return np.stack([p[..., 0] + c * d[..., 0] - s * d[..., 1], p[..., 1] + s * d[..., 0] + c * d[..., 1],
                     wrap_angle(p[..., 2] + d[..., 2])], axis=-1)


def inverse(p: np.ndarray) -> np.ndarray:
    """⊖p: the parent frame's pose in the frame of p."""
    p = np.asarray(p, dtype=float)
    return relative_pose(p, np.zeros_like(p))


def unicycle_from_increment(p0: np.ndarray, p1: np.ndarray, dt) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(v, ω, lateral) of the unicycle arc from pose p0 to p1 in ``dt`` (module docstring); vectorised.

    ``lateral`` [m]: the part of the increment across the chord that the arc cannot explain (slip).
    """
    d = relative_pose(p0, p1)
    h = 0.5 * d[..., 2]
    ch, sh = np.cos(h), np.sin(h)
    along = d[..., 0] * ch + d[..., 1] * sh
    lateral = -d[..., 0] * sh + d[..., 1] * ch
    dt = np.asarray(dt, dtype=float)
    return along * _sinc_half(d[..., 2]) / dt, d[..., 2] / dt, lateral


def unicycle_arc(p: np.ndarray, v, w, dt) -> np.ndarray:
    """The pose after driving the arc (v, ω) for ``dt`` from p (exact; the inverse of
    ``unicycle_from_increment``); vectorised."""
    dpsi = np.asarray(w, dtype=float) * dt
    s = np.asarray(v, dtype=float) * dt / _sinc_half(dpsi)   # chord length
    h = 0.5 * dpsi
    return compose(p, np.stack(np.broadcast_arrays(s * np.cos(h), s * np.sin(h), dpsi), axis=-1))


def map_to_odom(base_in_map: np.ndarray, base_in_odom: np.ndarray) -> np.ndarray:
    """The pose of odom in map, T_map,odom = T_map,base ∘ T_odom,base⁻¹ (what a localiser broadcasts)."""
    return compose(base_in_map, inverse(base_in_odom))


def sensor_to_base(pose: np.ndarray, P: np.ndarray, a: float, b: float) -> tuple[np.ndarray, np.ndarray]:
    """The filter's state (laser position, robot heading) → the pose of base_link and its covariance.

    base = p − R(φ)(a, b), for the laser ``a`` ahead and ``b`` left of base_link (``models``); the
    covariance through the Jacobian [[1, 0, a sin φ + b cos φ], [0, 1, −a cos φ + b sin φ], [0, 0, 1]].
    """
    pose = np.asarray(pose, dtype=float)
    c, s = math.cos(pose[2]), math.sin(pose[2])
    base = np.array([pose[0] - (a * c - b * s), pose[1] - (a * s + b * c), pose[2]])
    J = np.array([[1.0, 0.0, a * s + b * c], [0.0, 1.0, -a * c + b * s], [0.0, 0.0, 1.0]])
    return base, J @ np.asarray(P, dtype=float) @ J.T


def base_to_sensor(pose: np.ndarray, a: float, b: float) -> np.ndarray:
    """The pose of base_link → the filter's state: laser position p + R(φ)(a, b), same heading."""
    pose = np.asarray(pose, dtype=float)
    c, s = math.cos(pose[2]), math.sin(pose[2])
    return np.array([pose[0] + a * c - b * s, pose[1] + a * s + b * c, pose[2]])


class OdometryInputs:
    """Odometry messages → filter inputs (t, v, ω, cov) by ``motion`` (module docstring)."""

    def __init__(self, motion: str = 'increments') -> None:
        if motion not in MOTIONS:
            raise ValueError(f'motion = {motion!r}: must be one of {MOTIONS}')
        self.motion = motion
        self._prev: tuple | None = None
        self.max_lateral = 0.0   # the largest sideways slip dropped so far [m] (increments)

    def reset(self) -> None:
        self._prev = None

    def offer(self, t: float, pose: np.ndarray, v: float, w: float, cov: np.ndarray | None,
              tag=None) -> list[tuple[float, float, float, np.ndarray | None, object]]:
        """One message: its stamp [s], odom pose (x, y, yaw), twist (v, ω) and twist covariance (2×2 or None)
        → the inputs to give the filter now, in stamp order (none, or one): (t, v, ω, cov, tag), where
        ``tag`` is what the caller passed with the message whose stamp the input carries (its exact stamp)."""
        if self.motion == 'twist':
            return [(t, float(v), float(w), cov, tag)]
        prev, self._prev = self._prev, (t, np.asarray(pose, dtype=float).copy(), cov, tag)
        if prev is None or not t > prev[0]:
            return []
        vv, ww, lat = unicycle_from_increment(prev[1], self._prev[1], t - prev[0])
        self.max_lateral = max(self.max_lateral, abs(float(lat)))
        return [(prev[0], float(vv), float(ww), prev[2], prev[3])]


class OdomTrack:
    """The odom pose of base_link over time (module docstring): recorded poses, or dead reckoning."""

    def __init__(self, history: float = 30.0) -> None:
        self.history = history
        self._t: deque[float] = deque()
        self._p: deque[np.ndarray] = deque()
        self._twist = (0.0, 0.0)

    def reset(self) -> None:
        self._t.clear()
        self._p.clear()
        self._twist = (0.0, 0.0)

    def __len__(self) -> int:
        return len(self._t)

    def add(self, t: float, pose: np.ndarray, v: float = 0.0, w: float = 0.0) -> None:
        """A recorded odom pose (an Odometry message) and its twist (used after the last pose)."""
        self._t.append(float(t))
        self._p.append(np.asarray(pose, dtype=float).copy())
        self._twist = (float(v), float(w))
        while len(self._t) > 2 and self._t[-1] - self._t[1] > self.history:
            self._t.popleft()
            self._p.popleft()

    def integrate(self, t: float, v: float, w: float) -> None:
        """Dead reckoning: drive the held twist up to ``t`` (exact arc), then hold (v, ω) from ``t`` on."""
        pose = np.zeros(3) if not self._t else self.pose_at(t)
        self.add(t, pose, v, w)

    def pose_at(self, t: float) -> np.ndarray:
        """The odom pose at ``t``: interpolated between records, the last twist's arc after the last one,
        the first pose before the first one. Raises ``LookupError`` when nothing was recorded."""
        if not self._t:
            raise LookupError('no odometry yet')
        ts = self._t
        if t >= ts[-1]:
            return unicycle_arc(self._p[-1], *self._twist, t - ts[-1])
        if t <= ts[0]:
            return self._p[0].copy()
        times = np.fromiter(ts, float, len(ts))
        k = int(np.searchsorted(times, t, side='right'))
        t0, t1, p0, p1 = times[k - 1], times[k], self._p[k - 1], self._p[k]
        f = (t - t0) / (t1 - t0)
        out = p0 + f * (p1 - p0)
        out[2] = wrap_angle(p0[2] + f * wrap_angle(p1[2] - p0[2]))
        return out
