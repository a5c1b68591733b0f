"""Kalman tracker for position reports with a CV motion model (state [x, ẋ, y, ẏ])."""

from __future__ import annotations

import math

import numpy as np

from track_core.filters import check_covariance, cv_process_noise, cv_transition, kf_predict, kf_update
from track_core.filters.gating import GateDecision, InnovationGate

H_POS = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]])


class CVKalmanTracker:
    """Initialises on the first report (velocity prior ``sigma_v0``), then predict/update.

    Works on one track (z of shape (2,)) or on M tracks updated together (z of shape (M, 2)),
    which is how the Monte-Carlo experiment runs. ``update`` rejects out-of-order reports
    (t earlier than the last one) by raising ``ValueError``; the node turns that into a logged
    reason and keeps running. ``update_gated`` puts an ``InnovationGate`` in front of the update;
    ``reset`` forgets the track (after a clock jump, or when the gate says it was lost).
    """

    def __init__(self, q_s: float = 0.05, sigma_v0: float = 5.0) -> None:
        if not q_s >= 0:
            raise ValueError(f'q_s must be >= 0, got {q_s}')
        if not sigma_v0 > 0:
            raise ValueError(f'sigma_v0 must be > 0, got {sigma_v0}')
        self.q_s = q_s
        self.sigma_v0 = sigma_v0
        self.t: float | None = None
        self.x: np.ndarray | None = None
        self.P: np.ndarray | None = None

    @property
    def initialised(self) -> bool:
        return self.x is not None

    def reset(self) -> None:
        """Forget the track: the next report initialises a new one."""
        self.t = self.x = self.P = None

    def innovation(self, t: float, z: np.ndarray, R: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Innovation ν = z − H x⁻ of a report at ``t`` and its covariance S = H P⁻ Hᵀ + R (one track)."""
        x_pred, P_pred = self.predict(t)
        return np.asarray(z, dtype=float) - H_POS @ x_pred, H_POS @ P_pred @ H_POS.T + np.asarray(R, dtype=float)

    def update_gated(self, t: float, z: np.ndarray, R: np.ndarray,
                     gate: InnovationGate) -> tuple[GateDecision, np.ndarray | None, np.ndarray | None]:
        """``update`` when the gate accepts the report (one track); (decision, x, P), x and P None if refused.

        The first report of a track is not gated (there is no prediction); a lost track (the gate's
        ``reinitialise``) starts again from the report.
        """
        if self.x is None:
            decision = GateDecision(True, math.nan, gate.threshold)
        else:
            nu, S = self.innovation(t, z, R)
            decision = gate.check(nu, S, t - self.t)
            if not decision.accepted:
                return decision, None, None
            if decision.reinitialise:
                self.reset()
        x, P = self.update(t, z, R)
        return decision, x, P

    def predict(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Mean and covariance predicted to time ``t`` without changing the filter."""
        if self.x is None or self.t is None:
            raise ValueError('tracker not initialised')
        dt = t - self.t
        if dt < 0:
            raise ValueError(f'cannot predict backwards: t={t} < last t={self.t}')
        return kf_predict(self.x, self.P, cv_transition(dt), cv_process_noise(dt, self.q_s))

    def update(self, t: float, z: np.ndarray, R: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Fuse a position report z=[x, y] with covariance R taken at time t."""
        z = np.asarray(z, dtype=float)
        if z.shape[-1:] != (2,) or z.ndim > 2 or not np.all(np.isfinite(z)):
            raise ValueError(f'report must be 2 finite numbers, got {z!r}')
        R = check_covariance(R, 'report covariance', definite=True)
        if self.x is None:
            self.x = np.zeros((*z.shape[:-1], 4))
            self.x[..., [0, 2]] = z
            P0 = np.diag([R[0, 0], self.sigma_v0**2, R[1, 1], self.sigma_v0**2])
            P0[0, 2] = P0[2, 0] = R[0, 1]
            self.P = np.broadcast_to(P0, (*z.shape[:-1], 4, 4)).copy()
        else:
            x_pred, P_pred = self.predict(t)
            self.x, self.P, _, _ = kf_update(x_pred, P_pred, z, H_POS, R)
        self.t = t
        return self.x.copy(), self.P.copy()
