"""Planar poses (x, y, yaw) and a frame's pose over time: the SE(2) blocks odometry users share.

``relative_pose`` (p1 in the frame of p0), ``compose`` (p ⊕ d) and ``filters.invert_pose`` (⊖p); the
unicycle arc that joins two poses (``unicycle_from_increment``: with the increment (dx, dy, dψ) in the frame
of the first pose, ω = dψ/Δt and v = s/Δt, s = (dx cos(dψ/2) + dy sin(dψ/2))·(dψ/2)/sin(dψ/2), the arc length
of the chord projected on the mid-heading; a sideways slip, which a unicycle cannot make, is returned as
``lateral``) and its inverse (``unicycle_arc``). ``OdomTrack`` keeps a frame's recorded poses (a driver's
``nav_msgs/Odometry``: base_link in odom) and gives the pose at any time: linear interpolation between
records (shortest angle for yaw), the last twist's arc after the last one. Used by the SLAM node's odometry
input and by the RFID reader carried by a robot. All functions are vectorised over leading axes.
"""

from __future__ import annotations

from collections import deque

import numpy as np

from track_core.filters.angles import wrap_angle


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
