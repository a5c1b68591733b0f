"""The latest report of every track, brought to a common instant for pairwise scoring.

A track with a velocity (an Odometry track) is predicted to the common instant t with the
constant-velocity model: μ(t) = μ + v·Δt and R(t) = R + Δt²·R_v + q_s·Δt³/3·I (position
block of the CV process noise, eqs. 1–4 of the sonar paper; the position–velocity
cross-covariance is not carried by Odometry and is taken as zero). It drops out when Δt
exceeds ``max_prediction``. A track without a velocity (a position report) is used as it is
while it is at most ``stale_after`` seconds old, and drops out after that. Reports from the
future (Δt < 0, clock skew between sources) are used as they are when within the same
tolerance.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from track_core.fusion.config import AssociatorConfig

_A = AssociatorConfig()  # the defaults: the associator's


@dataclass(frozen=True)
class TrackReport:
    t: float
    mu: np.ndarray  # (2,)
    R: np.ndarray  # (2, 2)
    v: np.ndarray | None = None  # (2,)
    Rv: np.ndarray | None = None  # (2, 2)


class TrackTable:
    def __init__(self, stale_after: float = _A.stale_after, max_prediction: float = _A.max_prediction,
                 q_s: float = _A.q_s) -> None:
        if not stale_after > 0 or not max_prediction > 0 or not q_s >= 0:
            raise ValueError(f'need stale_after > 0, max_prediction > 0, q_s >= 0; got '
                             f'{stale_after}, {max_prediction}, {q_s}')
        self.stale_after, self.max_prediction, self.q_s = stale_after, max_prediction, q_s
        self.latest: dict[str, TrackReport] = {}

    def update(self, track_id: str, report: TrackReport) -> None:
        self.latest[track_id] = report

    def at(self, t: float) -> tuple[list[str], np.ndarray, np.ndarray]:
        """(ids, μ (n,2), R (n,2,2)) of every live track at instant ``t``, vectorised over tracks."""
        if not self.latest:
            return [], np.zeros((0, 2)), np.zeros((0, 2, 2))
        ids = list(self.latest)
        reps = [self.latest[i] for i in ids]
        dt = t - np.array([r.t for r in reps])
        mu = np.array([r.mu for r in reps], dtype=float)
        R = np.array([r.R for r in reps], dtype=float)
        has_v = np.array([r.v is not None for r in reps])
        v = np.array([r.v if r.v is not None else (0.0, 0.0) for r in reps], dtype=float)
        Rv = np.array([r.Rv if r.Rv is not None else np.zeros((2, 2)) for r in reps], dtype=float)
        ahead = np.clip(dt, 0.0, None)
        pred = has_v & (ahead > 0)
        mu = np.where(pred[:, None], mu + v * ahead[:, None], mu)
        grow = ahead[:, None, None] ** 2 * Rv + (self.q_s * ahead**3 / 3.0)[:, None, None] * np.eye(2)
        R = np.where(pred[:, None, None], R + grow, R)
        limit = np.where(has_v, self.max_prediction, self.stale_after)
        live = (dt <= limit) & (dt >= -self.stale_after)
        return [i for i, ok in zip(ids, live, strict=True) if ok], mu[live], R[live]
