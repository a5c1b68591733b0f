"""A transform buffer fed by ``/tf`` and ``/tf_static``, and planar CV states moved between frames.

Why: radars and trackers publish in their own frames (a radar's frame moves with its ship), and
tf2_ros is not on PyPI. The time interpolation and the composition of transforms are
pytransform3d's ``TemporalTransformManager`` (ScLERP between the samples of each edge); this
module keeps each edge's samples (bounded), decides whether a lookup is answerable, and reads the
messages.

- ``TransformBuffer.add(msg, static)``: every ``TransformStamped`` of a ``tf2_msgs/TFMessage``;
  a transform tf2 would refuse (bad frame ids, non-finite numbers, a zero quaternion) is skipped
  and its reason returned. Dynamic edges keep the samples of the last ``history`` seconds (at most
  ``max_samples``); a static edge keeps its latest value, valid at any time.
- ``lookup(target, source, t)``: the 4×4 pose of ``source`` in ``target`` at ``t``, or a reason:
  an unknown frame or no chain between them (names the frame), or a dynamic edge on the chain
  whose samples do not reach ``t`` (older than the buffer, or later than its latest sample by more
  than ``tolerance``: the transform is too old). Within ``tolerance`` after the latest sample the
  latest is used, as tf2's ``Buffer`` does with a timeout of zero plus a small slack.
- ``move_cv_states(...)``: states [x, ẋ, y, ẏ] and covariances from a frame to another through
  the planar part of the transform (yaw of its rotation, x/y of its translation). A velocity is
  moved with the frame's own motion: v' = R v + ω × (R p) + ṫ, with ω and ṫ from the transform a
  short time ``DT`` before (or after) ``t``; a velocity marked not estimated stays so.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

import numpy as np
from pytransform3d.transform_manager import NumpyTimeseriesTransform, StaticTransform, TemporalTransformManager

from track_msgs_py.covariance import not_estimated
from track_msgs_py.odometry import quaternion_matrix
from track_msgs_py.stamps import stamp_to_sec
from track_msgs_py.tf import frame_pair_problem

DT = 0.05              # the step used to measure a moving frame's velocity [s]
_POS, _VEL = [0, 2], [1, 3]


def _pq(tr) -> np.ndarray:
    p, q = tr.translation, tr.rotation
    return np.array([p.x, p.y, p.z, q.w, q.x, q.y, q.z], dtype=float)


@dataclass
class _Edge:
    parent: str
    static: bool
    times: deque = field(default_factory=deque)
    pqs: deque = field(default_factory=deque)
    dirty: bool = True


@dataclass
class TransformBuffer:
    """Bounded per-edge history of the transform tree; lookups through pytransform3d (module docstring)."""

    history: float = 10.0
    tolerance: float = 0.2
    max_samples: int = 10_000
    edges: dict = field(default_factory=dict)          # child → _Edge
    manager: TemporalTransformManager = field(default_factory=lambda: TemporalTransformManager(check=False))

    def clear(self) -> None:
        self.edges.clear()
        self.manager = TemporalTransformManager(check=False)

    def add(self, msg, static: bool = False) -> list[str]:
        reasons = []
        for tr in msg.transforms:
            parent, child = tr.header.frame_id, tr.child_frame_id
            reason = frame_pair_problem(parent, child)
            pq = _pq(tr.transform)
            if reason is None and not np.all(np.isfinite(pq)):
                reason = f'transform {parent} -> {child}: non-finite numbers'
            if reason is None and np.linalg.norm(pq[3:]) < 1e-9:
                reason = f'transform {parent} -> {child}: zero quaternion'
            if reason is not None:
                reasons.append(reason)
                continue
            pq[3:] /= np.linalg.norm(pq[3:])
            t = stamp_to_sec(tr.header.stamp)
            edge = self.edges.get(child)
            if edge is None or edge.parent != parent or edge.static != static:
                edge = self.edges[child] = _Edge(parent, static)
            if static:
                edge.times, edge.pqs = deque([t]), deque([pq])
            elif edge.times and t < edge.times[-1]:
                reasons.append(f'transform {parent} -> {child}: stamp {t:.3f} s before the latest '
                               f'{edge.times[-1]:.3f} s')
                continue
            elif edge.times and t == edge.times[-1]:
                edge.pqs[-1] = pq
            else:
                edge.times.append(t)
                edge.pqs.append(pq)
                while len(edge.times) > self.max_samples or (len(edge.times) > 1
                                                             and edge.times[0] < t - self.history):
                    edge.times.popleft()
                    edge.pqs.popleft()
            edge.dirty = True
        return reasons

    def _chain(self, frame: str) -> list[str]:
        chain, seen = [frame], {frame}
        while chain[-1] in self.edges:
            parent = self.edges[chain[-1]].parent
            if parent in seen:     # a loop in a hostile tree: stop at it
                break
            chain.append(parent)
            seen.add(parent)
        return chain

    def _path_problem(self, target: str, source: str, t: float) -> str | None:
        up_s, up_t = self._chain(source), self._chain(target)
        for name, up in ((source, up_s), (target, up_t)):
            if len(up) == 1 and not any(e.parent == name for e in self.edges.values()):
                return f'header.frame_id: unknown frame {name!r} (not on /tf or /tf_static)'
        common = next((f for f in up_s if f in set(up_t)), None)
        if common is None:
            return (f'header.frame_id: no transform chain from {source!r} to {target!r} '
                    f'(trees {up_s[-1]!r}, {up_t[-1]!r})')
        for up in (up_s, up_t):
            for child in up[:up.index(common)]:
                e = self.edges[child]
                if e.static:
                    continue
                if t > e.times[-1] + self.tolerance:
                    return (f'header.frame_id: transform {e.parent} -> {child} too old for {source!r}: latest at '
                            f'{e.times[-1]:.3f} s, input at {t:.3f} s (tolerance {self.tolerance:g} s)')
                if t < e.times[0] - 1e-9:
                    return (f'header.frame_id: transform {e.parent} -> {child} not known at {t:.3f} s for {source!r} '
                            f'(the buffer starts at {e.times[0]:.3f} s)')
        return None

    def _sync(self) -> None:
        for child, e in self.edges.items():
            if not e.dirty:
                continue
            if e.static:
                A2B = np.eye(4)
                A2B[:3, 3] = e.pqs[0][:3]
                w, x, y, z = e.pqs[0][3:]
                A2B[:3, :3] = quaternion_matrix(x, y, z, w)
                self.manager.add_transform(child, e.parent, StaticTransform(A2B))
            else:
                times, pqs = np.array(e.times), np.array(e.pqs)
                if times.size == 1:     # one sample: constant until the next (within the tolerance)
                    times, pqs = np.array([times[0], times[0] + 1e-6]), np.repeat(pqs, 2, axis=0)
                self.manager.add_transform(child, e.parent, NumpyTimeseriesTransform(times, pqs, time_clipping=True))
            e.dirty = False

    def lookup(self, target: str, source: str, t: float) -> tuple[np.ndarray | None, str | None]:
        """The pose of ``source`` in ``target`` at ``t`` (4×4), or ``(None, reason)``."""
        if target == source:
            return np.eye(4), None
        reason = self._path_problem(target, source, t)
        if reason is not None:
            return None, reason
        self._sync()
        return np.asarray(self.manager.get_transform_at_time(source, target, t), float), None

    def motion(self, target: str, source: str, t: float) -> tuple[np.ndarray, np.ndarray] | None:
        """Two poses of ``source`` in ``target`` DT apart around ``t`` ((T(a), T(b)) with b − a = DT), or None."""
        for a, b in ((t - DT, t), (t, t + DT)):
            Ta, ra = self.lookup(target, source, a)
            Tb, rb = self.lookup(target, source, b) if ra is None else (None, ra)
            if ra is None and rb is None and self._within(target, source, a, b):
                return Ta, Tb
        return None

    def _within(self, target: str, source: str, a: float, b: float) -> bool:
        """Both instants inside the samples of every dynamic edge (no clipping would fake a standstill)."""
        for frame in (*self._chain(source), *self._chain(target)):
            e = self.edges.get(frame)
            if e is not None and not e.static and not (e.times[0] - 1e-9 <= a and b <= e.times[-1] + 1e-9):
                return False
        return True


def _planar(T: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    yaw = math.atan2(T[1, 0], T[0, 0])
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s], [s, c]]), T[:2, 3].copy(), yaw


def move_cv_states(T: np.ndarray, x: np.ndarray, P: np.ndarray,
                   motion: tuple[np.ndarray, np.ndarray] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """States (n, 4) [x, ẋ, y, ẏ] and covariances (n, 4, 4) through the planar part of ``T`` (module docstring).

    ``motion``: (T(a), T(a + DT)) of the same frame, for a frame that moves; None for a fixed one. A
    state whose velocity is not estimated keeps it so (0, its variances, no cross terms)."""
    x, P = np.asarray(x, float).reshape(-1, 4), np.asarray(P, float).reshape(-1, 4, 4)
    R, t, _ = _planar(T)
    W = np.zeros((2, 2))
    tdot = np.zeros(2)
    if motion is not None:
        _, ta, ya = _planar(motion[0])
        _, tb, yb = _planar(motion[1])
        omega = math.remainder(yb - ya, 2 * math.pi) / DT
        W = np.array([[0.0, -omega], [omega, 0.0]])
        tdot = (tb - ta) / DT
    M = np.zeros((4, 4))
    M[np.ix_(_POS, _POS)] = R
    M[np.ix_(_VEL, _VEL)] = R
    M[np.ix_(_VEL, _POS)] = W @ R
    out_x, out_P = np.empty_like(x), np.empty_like(P)
    for k in range(x.shape[0]):
        p_map = R @ x[k, _POS] + t
        if np.any(not_estimated(np.diag(P[k])[_VEL])):
            out_x[k] = 0.0
            out_x[k, _POS] = p_map
            out_P[k] = P[k]
            out_P[k][np.ix_(_POS, _POS)] = R @ P[k][np.ix_(_POS, _POS)] @ R.T
            continue
        v_map = R @ x[k, _VEL] + W @ (p_map - t) + tdot
        out_x[k, _POS], out_x[k, _VEL] = p_map, v_map
        out_P[k] = M @ P[k] @ M.T
    return out_x, out_P
