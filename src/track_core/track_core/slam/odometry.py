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

import numpy as np

from track_core.filters import invert_pose
from track_core.filters.poses import compose, unicycle_from_increment

MOTIONS = ('increments', 'twist')


def map_to_odom(base_in_map: np.ndarray, base_in_odom: np.ndarray) -> np.ndarray:
    """The pose of odom in map, T_map,odom = T_map,base ∘ T_odom,base⁻¹ (what a localiser broadcasts)."""
    return compose(base_in_map, invert_pose(base_in_odom))


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
