"""EKF-SLAM and the Compressed EKF (paper's ref. [9], Guivant & Nebot 2001) in one class.

State ``X = [x, y, φ, m₁ₓ, m₁ᵧ, …]`` (vehicle at the laser, point landmarks in creation order).

Compressed EKF (issue 7 §2). The state is partitioned into the active part A (vehicle +
landmarks within ``local_radius`` of the vehicle when the phase starts) and the passive part B.
In the local phase only X_A, P_AA are predicted/updated while, from φ = I, ψ = 0, θ = 0,

- prediction with Jacobian J on A:  φ ← J φ
- update with H = [H_a 0], S = H_a P_AA H_aᵀ + R, μ = H_aᵀS⁻¹H_a, β = H_aᵀS⁻¹ν (P_AA before the
  update):  ψ ← ψ + φᵀμφ,  θ ← θ + φᵀβ,  φ ← (I − P_AA μ) φ

and the global update (when the vehicle is more than ``local_exit`` from the phase centre, or
on request) uses P_AB from the start of the phase: X_B ← X_B + P_BA θ, P_BB ← P_BB − P_BA ψ P_AB,
P_AB ← φ P_AB, followed by a repartition. The result equals the full EKF (tested to 1e-9).

Interpretation (new landmarks during a local phase, not covered by the issue's formulas): a new
landmark m = g(x_v, z) joins A. Its cross-covariance with B is G_v P_vB = G_v φ_v P_A₀B, so φ
becomes rectangular (n_A × n_A₀): the new landmark's row is G_v φ_v, while ψ and θ stay in the
dimension of A at the phase start (A₀). The global update then writes P_AB = φ P_A₀B for every
row of A, including the new landmarks; this is exact.

With ``compressed=False`` A is the whole state and B is empty: the plain (full) EKF-SLAM, with
the same prediction (O(n) for the sparse vehicle Jacobian), association and joint scan update.
One scan = one joint update of all associated observations (associated against the prior of
the scan), then initialisation of new landmarks from the updated pose.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from track_core.filters import symmetrize, wrap_angle
from track_core.slam.association import Association, associate, innovation_covariances
from track_core.slam.models import (
    VehicleParams,
    inverse_observe,
    inverse_observe_jacobians,
    observe,
    observe_jacobians,
    vehicle_jacobians,
    vehicle_step,
)

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class SlamParams:
    """Noise, gates and CEKF partition sizes. Defaults suit the Victoria Park run."""

    sigma_v: float = 0.5             # encoder speed noise [m/s]
    sigma_steer: float = np.deg2rad(3.0)  # steering noise [rad]
    q_pose: tuple[float, float, float] = (0.0, 0.0, 0.0)  # additive pose noise density [·²/s]
    sigma_r: float = 0.5             # range noise [m]
    sigma_b: float = np.deg2rad(1.0)  # bearing noise [rad]
    gate: float = 9.21               # χ²₂ 99 % individual-compatibility gate
    new_gate: float = 18.42          # χ²₂ 99.99 %: farther than this from every landmark → new
    max_range: float = 30.0          # sensor range used for "in view" [m]
    init_max_range: float = 30.0     # only observations closer than this start landmarks [m]
    local_radius: float = 60.0       # CEKF: landmarks within this of the vehicle form A [m]
    local_exit: float = 20.0         # CEKF: global update when the vehicle moves this far [m]
    n_sigma: float = 3.0             # failure detector (see association.py)
    sep_fraction: float = 0.5
    min_separation: float = 1.5

    def __post_init__(self) -> None:
        for name in ('sigma_v', 'sigma_steer', 'sigma_r', 'sigma_b', 'gate', 'max_range', 'init_max_range',
                     'local_radius', 'local_exit', 'n_sigma', 'sep_fraction'):
            v = getattr(self, name)
            if not (v > 0):
                raise ValueError(f'{name} = {v}: must be > 0')
        if self.new_gate < self.gate:
            raise ValueError(f'new_gate = {self.new_gate}: must be >= gate ({self.gate})')
        if self.local_radius < self.max_range + self.local_exit:
            raise ValueError(f'local_radius = {self.local_radius}: must be >= max_range + local_exit '
                             f'({self.max_range + self.local_exit}) so every visible landmark is active')
        if self.min_separation < 0:
            raise ValueError(f'min_separation = {self.min_separation}: must be >= 0')

    @property
    def R(self) -> np.ndarray:  # noqa: N802 (the paper's R)
        return np.diag([self.sigma_r**2, self.sigma_b**2])


class CekfSlam:
    """EKF/CEKF SLAM driven one input (``predict``) and one scan (``update``) at a time."""

    def __init__(self, pose0: np.ndarray, P0: np.ndarray, params: SlamParams | None = None, *,
                 compressed: bool = True, vehicle: VehicleParams | None = None) -> None:
        P0 = np.asarray(P0, dtype=float)
        if P0.shape != (3, 3):
            raise ValueError(f'P0 shape = {P0.shape}: must be (3, 3)')
        self.params = params or SlamParams()
        self.vehicle = vehicle or VehicleParams()
        self.compressed = compressed
        self.x = np.asarray(pose0, dtype=float).copy()
        self.P = P0.copy()
        self.n_global_updates = 0
        self._repartition()

    # ------------------------------------------------------------------ bookkeeping
    @property
    def n_landmarks(self) -> int:
        return (self._n_total - 3) // 2

    @property
    def pose(self) -> np.ndarray:
        return self.xa[:3].copy()

    @property
    def pose_cov(self) -> np.ndarray:
        return self.Paa[:3, :3].copy()

    @property
    def n_active_landmarks(self) -> int:
        return (self.xa.size - 3) // 2

    def _repartition(self) -> None:
        """Start a local phase: A = vehicle + landmarks within ``local_radius`` (Guivant & Nebot)."""
        n = self.x.size
        self._n_total = n
        lm = self.x[3:].reshape(-1, 2)
        if self.compressed:
            near = np.flatnonzero(np.linalg.norm(lm - self.x[:2], axis=1) <= self.params.local_radius)
        else:
            near = np.arange(lm.shape[0])
        self.a_idx = np.concatenate([np.arange(3), (3 + 2 * near[:, None] + np.arange(2)).ravel()]).astype(int)
        self.a0_idx = self.a_idx.copy()
        mask = np.ones(n, bool)
        mask[self.a_idx] = False
        self.b_idx = np.flatnonzero(mask)
        self.track = self.b_idx.size > 0
        if self.track:
            self.xa = self.x[self.a_idx]
            self.Paa = self.P[np.ix_(self.a_idx, self.a_idx)]
            na = self.a_idx.size
            self.phi = np.eye(na)
            self.psi = np.zeros((na, na))
            self.theta = np.zeros(na)
        else:  # A is everything: work on the arrays themselves
            self.xa, self.Paa = self.x, self.P
        self.center = self.xa[:2].copy()

    def global_update(self) -> None:
        """CEKF global update (issue 7 §2) followed by a repartition; a no-op copy when B = ∅."""
        if self.track:
            b, a0 = self.b_idx, self.a0_idx
            P_BA = self.P[np.ix_(b, a0)]
            self.x[b] += P_BA @ self.theta
            self.P[np.ix_(b, b)] -= P_BA @ self.psi @ P_BA.T
            P_AB = self.phi @ P_BA.T
        n_old, n_new = self.x.size, self._n_total
        if n_new > n_old or self.track:
            x = np.zeros(n_new)
            x[:n_old] = self.x
            P = np.zeros((n_new, n_new))
            P[:n_old, :n_old] = self.P
            a = self.a_idx
            x[a] = self.xa
            P[np.ix_(a, a)] = self.Paa
            if self.track:
                P[np.ix_(a, self.b_idx)] = P_AB
                P[np.ix_(self.b_idx, a)] = P_AB.T
            self.x, self.P = x, symmetrize(P)
        self.n_global_updates += 1
        self._repartition()

    def mean_cov(self) -> tuple[np.ndarray, np.ndarray]:
        """Full (x, P) of the EKF; in compressed mode this performs a global update first."""
        if self.track or self.xa is not self.x:
            self.global_update()
        return self.x.copy(), self.P.copy()

    def landmarks(self) -> np.ndarray:
        """Landmark means (L, 2): active ones current, passive ones as of the last global update."""
        x = np.zeros(self._n_total)
        x[:self.x.size] = self.x
        x[self.a_idx] = self.xa
        return x[3:].reshape(-1, 2)

    # ------------------------------------------------------------------ filter steps
    def predict(self, u: np.ndarray, dt: float) -> None:
        """Prediction over ``dt`` with input u = (v_e, α) on A (φ ← Jφ)."""
        if dt <= 0:
            return
        p = self.params
        pose = self.xa[:3]
        F, G = vehicle_jacobians(pose, u, dt, self.vehicle)
        Q = G @ np.diag([p.sigma_v**2, p.sigma_steer**2]) @ G.T + dt * np.diag(p.q_pose)
        self.xa[:3] = vehicle_step(pose, u, dt, self.vehicle)
        Paa = self.Paa
        Paa[:3, :] = F @ Paa[:3, :]
        Paa[:, :3] = Paa[:, :3] @ F.T
        Paa[:3, :3] += Q
        if self.track:
            self.phi[:3] = F @ self.phi[:3]

    def _predicted(self):
        pose = self.xa[:3]
        lm = self.xa[3:].reshape(-1, 2)
        m = lm.shape[0]
        Hv, Hm = observe_jacobians(pose, lm)
        zhat = observe(pose, lm)
        i = 3 + 2 * np.arange(m)
        rows = i[:, None, None] + np.arange(2)[None, :, None]
        cols = i[:, None, None] + np.arange(2)[None, None, :]
        Pmm = self.Paa[rows, cols]
        Pvm = self.Paa[:3, 3:].reshape(3, m, 2).transpose(1, 0, 2)
        S_state = innovation_covariances(Hv, Hm, self.Paa[:3, :3], Pvm, Pmm)
        return lm, Hv, Hm, zhat, S_state

    def associate(self, z: np.ndarray) -> tuple[Association, tuple]:
        """Associate a scan ``z`` (n, 2) of (range, bearing eq. 5) against the active landmarks."""
        p = self.params
        pred = self._predicted()
        lm, _, _, zhat, S_state = pred
        a = associate(z, zhat, S_state, p.R, lm, gate=p.gate, new_gate=p.new_gate,
                      init_max_range=p.init_max_range, max_range=p.max_range, n_sigma=p.n_sigma,
                      sep_fraction=p.sep_fraction, min_separation=p.min_separation)
        return a, pred

    def update(self, z: np.ndarray, *, assoc: Association | None = None, init_new: bool = True) -> Association:
        """One scan: (local-area check), association, joint EKF update, new landmarks."""
        z = np.asarray(z, dtype=float).reshape(-1, 2)
        if self.compressed and np.linalg.norm(self.xa[:2] - self.center) > self.params.local_exit:
            self.global_update()
        a, pred = self.associate(z) if assoc is None else (assoc, self._predicted())
        if a.obs.size:
            self.update_known(z[a.obs], a.lm, pred)
        if init_new and a.new.size:
            self.add_landmarks(z[a.new])
        return a

    def update_known(self, z: np.ndarray, lm_local: np.ndarray, pred: tuple | None = None) -> None:
        """Joint EKF/CEKF update with observations z (k, 2) of active landmarks ``lm_local`` (distinct)."""
        z = np.asarray(z, dtype=float).reshape(-1, 2)
        lm_local = np.asarray(lm_local, dtype=int)
        k = lm_local.size
        if k == 0:
            return
        _, Hv, Hm, zhat, _ = self._predicted() if pred is None else pred
        cols = np.concatenate([np.arange(3), (3 + 2 * lm_local[:, None] + np.arange(2)).ravel()])
        Hc = np.zeros((2 * k, 3 + 2 * k))
        r2 = np.arange(2 * k).reshape(k, 2)
        Hc[:, :3] = Hv[lm_local].reshape(2 * k, 3)
        Hc[r2[:, :, None], 3 + r2[:, None, :]] = Hm[lm_local]
        nu = z - zhat[lm_local]
        nu[:, 1] = wrap_angle(nu[:, 1])
        nu = nu.ravel()
        PHt = self.Paa[:, cols] @ Hc.T
        S = Hc @ PHt[cols] + np.kron(np.eye(k), self.params.R)
        Sinv_nu = np.linalg.solve(S, nu)
        W = np.linalg.solve(S, PHt.T)
        if self.track:
            Hphi = Hc @ self.phi[cols]
            Sinv_Hphi = np.linalg.solve(S, Hphi)
            self.psi += Hphi.T @ Sinv_Hphi
            self.theta += Hphi.T @ Sinv_nu
            self.phi -= PHt @ Sinv_Hphi
        self.xa += PHt @ Sinv_nu
        self.xa[2] = wrap_angle(self.xa[2])
        self.Paa -= PHt @ W
        self.Paa[...] = symmetrize(self.Paa)

    def add_landmarks(self, z: np.ndarray) -> None:
        """Landmark initialisation m = g(x_v, z) (inverse of eq. 5), joining A (see module docstring)."""
        z = np.asarray(z, dtype=float).reshape(-1, 2)
        q = z.shape[0]
        if q == 0:
            return
        pose = self.xa[:3]
        m = inverse_observe(pose, z)
        Gv, Gz = inverse_observe_jacobians(pose, z)
        Gv = Gv.reshape(2 * q, 3)
        P_nA = Gv @ self.Paa[:3, :]
        blk = Gz @ self.params.R @ np.swapaxes(Gz, -1, -2)
        P_nn = Gv @ self.Paa[:3, :3] @ Gv.T
        idx = np.arange(2 * q).reshape(q, 2)
        P_nn[idx[:, :, None], idx[:, None, :]] += blk
        na = self.xa.size
        xa = np.concatenate([self.xa, m.ravel()])
        Paa = np.empty((na + 2 * q, na + 2 * q))
        Paa[:na, :na] = self.Paa
        Paa[na:, :na] = P_nA
        Paa[:na, na:] = P_nA.T
        Paa[na:, na:] = symmetrize(P_nn)
        new_idx = np.arange(self._n_total, self._n_total + 2 * q)
        self._n_total += 2 * q
        self.a_idx = np.concatenate([self.a_idx, new_idx])
        if self.track:
            self.phi = np.vstack([self.phi, Gv @ self.phi[:3]])
            self.xa, self.Paa = xa, Paa
        else:
            self.x, self.P = xa, Paa
            self.xa, self.Paa = self.x, self.P

    def set_vehicle(self, pose: np.ndarray, Pvv: np.ndarray, Pvm: np.ndarray) -> None:
        """Replace the vehicle mean, covariance and vehicle–map cross-covariance (3, 2L); restarts A."""
        self.mean_cov()
        self.x[:3] = pose
        self.P[:3, :3] = Pvv
        self.P[:3, 3:] = Pvm
        self.P[3:, :3] = Pvm.T
        self.P = symmetrize(self.P)
        self._repartition()
