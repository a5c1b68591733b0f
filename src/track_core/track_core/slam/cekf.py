"""EKF-SLAM and the Compressed EKF (paper's ref. [9], Guivant & Nebot 2001) in one class.

State ``X = [x, y, φ, m₁ₓ, m₁ᵧ, …]`` (vehicle at the laser, point landmarks in creation order).

Compressed EKF (the paper's §2). The state is partitioned into the active part A (vehicle +
landmarks within ``local_radius`` of the vehicle when the phase starts) and the passive part B. In
the local phase only X_A, P_AA are predicted/updated while, from φ = I, ψ = 0, θ = 0,

- prediction with Jacobian J on A:  φ ← J φ
- update with H = [H_a 0], S = H_a P_AA H_aᵀ + R, μ = H_aᵀS⁻¹H_a, β = H_aᵀS⁻¹ν (P_AA before the
  update):  ψ ← ψ + φᵀμφ,  θ ← θ + φᵀβ,  φ ← (I − P_AA μ) φ

and the global update (when the vehicle is more than ``local_exit`` from the phase centre, or on
request) uses P_AB from the start of the phase: X_B ← X_B + P_BA θ, P_BB ← P_BB − P_BA ψ P_AB,
P_AB ← φ P_AB, followed by a repartition. The result equals the full EKF (tested to 1e-9). A new
landmark in a local phase joins A with the row G_v φ_v of a rectangular φ (n_A × n_A₀).

With ``compressed=False`` A is the whole state and B is empty: the plain (full) EKF-SLAM. One scan =
one joint update of all associated observations (against the scan's prior), then new landmarks from
the updated pose. Prediction is batched exactly (Φ = I + (Σ vᵢ) e₃ᵀ, Q accumulated on 3×3, applied
when P_AA is next needed); the scan update reuses one Cholesky factor of S.

Tentative landmarks (``min_obs`` > 1, for real data): a new observation is held outside the filter
until confirmed in ``min_obs`` scans (Mahalanobis distance below ``tentative_gate``), dropped after
``tentative_max_gap`` scans without one. ``min_obs = 1`` (default) is immediate initialisation. Why
and what it costs: docs/MODULES.md, "The compressed EKF".
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from scipy.linalg import cho_factor, cho_solve

from track_core.filters import wrap_angle
from track_core.slam.association import Association, associate
from track_core.slam.models import (
    InputModel,
    VehicleParams,
    inverse_observe,
    inverse_observe_jacobians,
    vehicle_step_scalar,
)

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class ScanAssociation:
    """What one ``CekfSlam.update`` did with its scan (``association_log``): the observations it fused
    and the landmark number (creation order, the state's m₁, m₂, …) of each, then the observations that
    started landmarks and their numbers. Observations neither fused nor mapped (between the gates,
    beyond ``max_range``, tentative sightings) are in neither list. This is the association a smoother
    needs to solve the same problem as the filter."""

    scan: int                # ``CekfSlam.n_scans`` after this update
    z: np.ndarray            # (k, 2) fused observations (range, bearing eq. 5)
    landmarks: np.ndarray    # (k,) their landmark numbers
    z_new: np.ndarray        # (q, 2) observations that started landmarks
    new: np.ndarray          # (q,) the landmark numbers they started


@dataclass(frozen=True)
class SlamParams:
    """Noise, gates and CEKF partition sizes. Defaults suit the Victoria Park run."""

    sigma_v: float = 0.5             # σ of the first input: encoder speed (ACFR) or speed v (unicycle) [m/s]
    sigma_steer: float = np.deg2rad(3.0)  # σ of the second input: steering [rad] (ACFR) or yaw rate ω [rad/s]
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
    risk_fraction: float = 0.0       # failure detector: fraction of in-view landmarks that must be at risk
    min_obs: int = 1                 # scans a new feature must be seen in before it is mapped (1 = at once)
    tentative_gate: float = 9.21     # χ²₂ gate for confirming a tentative feature
    tentative_max_gap: int = 2       # a tentative feature unseen for more scans than this is dropped
    max_landmarks: int = 2000        # map-size cap: new landmarks beyond it are refused (Victoria Park maps 277)

    def __post_init__(self) -> None:
        for name in ('sigma_v', 'sigma_steer', 'sigma_r', 'sigma_b', 'gate', 'max_range', 'init_max_range',
                     'local_radius', 'local_exit', 'n_sigma', 'sep_fraction', 'tentative_gate'):
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
        if not 0.0 <= self.risk_fraction <= 1.0:
            raise ValueError(f'risk_fraction = {self.risk_fraction}: must be in [0, 1]')
        if self.min_obs < 1:
            raise ValueError(f'min_obs = {self.min_obs}: must be >= 1')
        if self.tentative_max_gap < 1:
            raise ValueError(f'tentative_max_gap = {self.tentative_max_gap}: must be >= 1')
        if self.max_landmarks < 1:
            raise ValueError(f'max_landmarks = {self.max_landmarks}: must be >= 1')

    @property
    def R(self) -> np.ndarray:  # noqa: N802 (the paper's R)
        return np.diag([self.sigma_r**2, self.sigma_b**2])


class CekfSlam:
    """EKF/CEKF SLAM driven one input (``predict``) and one scan (``update``) at a time.

    ``x``/``P`` are the full state (in compressed mode the active part is current only after a
    global update, see ``mean_cov``); ``xa``/``Paa`` the active part. ``Paa``, ``P`` and ``phi``
    are properties that first apply any pending (batched) prediction.
    """

    def __init__(self, pose0: np.ndarray, P0: np.ndarray, params: SlamParams | None = None, *,
                 compressed: bool = True, vehicle: InputModel | None = None) -> None:
        P0 = np.asarray(P0, dtype=float)
        if P0.shape != (3, 3):
            raise ValueError(f'P0 shape = {P0.shape}: must be (3, 3)')
        self.params = params or SlamParams()
        self.vehicle = vehicle or VehicleParams()
        self.compressed = compressed
        self.x = np.asarray(pose0, dtype=float).copy()
        self._P = P0.copy()
        self.n_global_updates = 0
        self.n_scans = 0
        self.n_refused_landmarks = 0  # observations that would have started a landmark beyond ``max_landmarks``
        self._refused_untold = 0  # ... of which ``take_refused_landmarks`` has not told yet
        # pending prediction: Φ = I + [c0, c1, 0]ᵀ e₃ᵀ and Q (upper triangle q00 q01 q02 q11 q12 q22)
        self._pending = False
        self._c = [0.0, 0.0]
        self._q = [0.0] * 6
        self._dirty = False          # anything done to A since the last repartition
        #: ``None`` (default) or a list to which every ``update`` appends its ``ScanAssociation``
        self.association_log: list[ScanAssociation] | None = None
        p = self.params
        self._su = (p.sigma_v**2, p.sigma_steer**2, *p.q_pose)
        self._clear_tentative()
        self._repartition()

    def _clear_tentative(self) -> None:
        """Forget the tentative features (min_obs > 1): position, sensor covariance, count, last scan."""
        self._tent = np.zeros((0, 2))
        self._tent_cov = np.zeros((0, 2, 2))
        self._tent_n = np.zeros(0, dtype=int)
        self._tent_last = np.zeros(0, dtype=int)

    # ------------------------------------------------------------------ lazily predicted arrays
    @property
    def Paa(self) -> np.ndarray:  # noqa: N802
        self._flush()
        return self._Paa

    @Paa.setter
    def Paa(self, value: np.ndarray) -> None:  # noqa: N802
        self._flush()
        self._Paa = value
        if not self.track:
            self._P = value

    @property
    def P(self) -> np.ndarray:  # noqa: N802
        self._flush()
        return self._P

    @P.setter
    def P(self, value: np.ndarray) -> None:  # noqa: N802
        self._flush()
        self._P = value
        if not self.track:
            self._Paa = value

    @property
    def phi(self) -> np.ndarray:
        self._flush()
        return self._phi

    def _flush(self) -> None:
        """Apply the pending batched prediction: P_AA ← Φ P_AA Φᵀ + Q, φ ← Φ φ (O(n_A))."""
        if not self._pending:
            return
        c0, c1 = self._c
        q00, q01, q02, q11, q12, q22 = self._q
        P = self._Paa
        P[0] += c0 * P[2]
        P[1] += c1 * P[2]
        P[:, 0] += c0 * P[:, 2]
        P[:, 1] += c1 * P[:, 2]
        P[0, 0] += q00
        P[1, 1] += q11
        P[2, 2] += q22
        P[0, 1] += q01
        P[1, 0] += q01
        P[0, 2] += q02
        P[2, 0] += q02
        P[1, 2] += q12
        P[2, 1] += q12
        if self.track:
            phi = self._phi
            phi[0] += c0 * phi[2]
            phi[1] += c1 * phi[2]
        self._pending = False
        self._c = [0.0, 0.0]
        self._q = [0.0] * 6

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

    @property
    def n_tentative(self) -> int:
        return int(self._tent_n.size)

    def _repartition(self) -> None:
        """Start a local phase: A = vehicle + landmarks within ``local_radius`` (Guivant & Nebot)."""
        self._flush()
        n = self.x.size
        self._n_total = n
        lm = self.x[3:].reshape(-1, 2)
        if self.compressed:
            d = lm - self.x[:2]
            near = np.flatnonzero(np.einsum('ij,ij->i', d, d) <= self.params.local_radius**2)
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
            self._Paa = self._P[np.ix_(self.a_idx, self.a_idx)]
            na = self.a_idx.size
            self._phi = np.eye(na)
            self.psi = np.zeros((na, na))
            self.theta = np.zeros(na)
        else:  # A is everything: work on the arrays themselves
            self.xa, self._Paa = self.x, self._P
            self._phi = np.zeros((0, 0))
        self._dirty = False
        self.center = self.xa[:2].copy()

    def global_update(self) -> None:
        """CEKF global update (the paper's §2) followed by a repartition; a no-op copy when B = ∅."""
        self._flush()
        n_old, n_new = self.x.size, self._n_total
        if self.track and self._dirty:
            P, a0 = self._P, self.a0_idx
            W = P[:, a0]                                  # [P_BA₀; P_A₀A₀] from the phase start
            PA = self._phi @ W.T                          # its B columns are the new P_AB = φ P_A₀B
            self.x += W @ self.theta                      # X_B ← X_B + P_BA θ (A rows rewritten below)
            psi = 0.5 * (self.psi + self.psi.T)
            P -= (W @ psi) @ W.T                          # P_BB ← P_BB − P_BA ψ P_AB, in place
        if n_new > n_old:
            x = np.zeros(n_new)
            x[:n_old] = self.x
            P = np.zeros((n_new, n_new))
            P[:n_old, :n_old] = self._P
            self.x, self._P = x, P
        if self.track and self._dirty:
            a, b = self.a_idx, self.b_idx
            rows = np.empty((a.size, n_new))
            rows[:, b] = PA[:, b]
            rows[:, a] = self._Paa
            self.x[a] = self.xa
            self._P[a, :] = rows
            self._P[:, a] = rows.T
            P = self._P
            P += P.T
            P *= 0.5
        self.n_global_updates += 1
        self._repartition()

    def mean_cov(self) -> tuple[np.ndarray, np.ndarray]:
        """Full (x, P) of the EKF; in compressed mode this performs a global update first."""
        self._flush()
        if self.track or self.xa is not self.x:
            self.global_update()
        return self.x.copy(), self._P.copy()

    def landmarks(self) -> np.ndarray:
        """Landmark means (L, 2): active ones current, passive ones as of the last global update."""
        x = np.zeros(self._n_total)
        x[:self.x.size] = self.x
        x[self.a_idx] = self.xa
        return x[3:].reshape(-1, 2)

    def map_estimate(self) -> tuple[np.ndarray, np.ndarray]:
        """Landmark means (L, 2) and 2×2 covariances (L, 2, 2) of the full EKF, filter untouched.

        Equal to the blocks ``mean_cov`` returns, but without its global update and repartition:
        the passive part is corrected on the fly, x_B + P_BA θ and the diagonal blocks of
        P_BB − P_BA ψ P_AB (O(n_B·n_A²), no n×n matrix is formed or copied).
        """
        Paa = self.Paa
        n, L = self._n_total, self.n_landmarks
        x = np.zeros(n)
        x[:self.x.size] = self.x
        cov = np.zeros((n, 2))                      # rows of the 2×2 diagonal blocks, stacked
        m0 = (self.x.size - 3) // 2
        i = 3 + 2 * np.arange(m0)
        P = self._P
        cov[i, 0], cov[i, 1] = P[i, i], P[i, i + 1]
        cov[i + 1, 0], cov[i + 1, 1] = P[i + 1, i], P[i + 1, i + 1]
        b = self.b_idx
        if self.track and b.size:
            W = P[np.ix_(b, self.a0_idx)]
            x[b] += W @ self.theta
            K = W @ (0.5 * (self.psi + self.psi.T))
            corr = np.einsum('lik,ljk->lij', K.reshape(-1, 2, K.shape[1]), W.reshape(-1, 2, W.shape[1]))
            cov[b] -= corr.reshape(-1, 2)
        a = self.a_idx
        x[a] = self.xa
        ja = np.arange(3, a.size, 2)
        cov[a[ja], 0], cov[a[ja], 1] = Paa[ja, ja], Paa[ja, ja + 1]
        cov[a[ja + 1], 0], cov[a[ja + 1], 1] = Paa[ja + 1, ja], Paa[ja + 1, ja + 1]
        return x[3:].reshape(L, 2), cov[3:].reshape(L, 2, 2)

    def tentative(self) -> np.ndarray:
        """Global positions (T, 2) of the tentative (not yet mapped) features."""
        return self._tent.copy()

    # ------------------------------------------------------------------ filter steps
    def predict(self, u: np.ndarray, dt: float, Su: np.ndarray | None = None) -> None:
        """Prediction over ``dt`` with input u on A (φ ← Jφ); batched, see module docstring.

        u = (v_e, α) for the ACFR model, (v, ω) for the unicycle (``models``). Input noise: ``Su``, a
        2×2 covariance of u for this step (an odometry message's twist covariance), else
        diag(``sigma_v``², ``sigma_steer``²) of the parameters.
        """
        if not dt > 0:
            return
        xa = self.xa
        nx, ny, nph, a, b, g00, g01, g10, g11, g20, g21 = vehicle_step_scalar(
            float(xa[0]), float(xa[1]), float(xa[2]), float(u[0]), float(u[1]), float(dt), self.vehicle)
        xa[0], xa[1], xa[2] = nx, ny, nph
        sv, sa, qx, qy, qp = self._su
        q00, q01, q02, q11, q12, q22 = self._q
        if Su is None:
            self._q = [q00 + 2.0 * a * q02 + a * a * q22 + sv * g00 * g00 + sa * g01 * g01 + dt * qx,
                       q01 + a * q12 + b * q02 + a * b * q22 + sv * g00 * g10 + sa * g01 * g11,
                       q02 + a * q22 + sv * g00 * g20 + sa * g01 * g21,
                       q11 + 2.0 * b * q12 + b * b * q22 + sv * g10 * g10 + sa * g11 * g11 + dt * qy,
                       q12 + b * q22 + sv * g10 * g20 + sa * g11 * g21,
                       q22 + sv * g20 * g20 + sa * g21 * g21 + dt * qp]
        else:  # G Σ Gᵀ with a full 2×2 Σ: the same entries plus the cross term s01 (gᵢ₀gⱼ₁ + gᵢ₁gⱼ₀)
            sv, sa, sc = float(Su[0, 0]), float(Su[1, 1]), float(Su[0, 1])
            self._q = [q00 + 2.0 * a * q02 + a * a * q22 + sv * g00 * g00 + sa * g01 * g01 + 2.0 * sc * g00 * g01
                       + dt * qx,
                       q01 + a * q12 + b * q02 + a * b * q22 + sv * g00 * g10 + sa * g01 * g11
                       + sc * (g00 * g11 + g01 * g10),
                       q02 + a * q22 + sv * g00 * g20 + sa * g01 * g21 + sc * (g00 * g21 + g01 * g20),
                       q11 + 2.0 * b * q12 + b * b * q22 + sv * g10 * g10 + sa * g11 * g11 + 2.0 * sc * g10 * g11
                       + dt * qy,
                       q12 + b * q22 + sv * g10 * g20 + sa * g11 * g21 + sc * (g10 * g21 + g11 * g20),
                       q22 + sv * g20 * g20 + sa * g21 * g21 + 2.0 * sc * g20 * g21 + dt * qp]
        self._c[0] += a
        self._c[1] += b
        self._pending = True
        self._dirty = True

    def _predicted(self):
        """Predicted observations of every active landmark, their Jacobians and Sⱼ − R (fused, O(n_A)).

        Same values as ``models.observe``/``observe_jacobians`` and
        ``association.innovation_covariances`` (tested), written out for 2×2 blocks: with
        d = m − p, C = Cov(d), c = Cov(d, φ), h₀/h₁ the rows of ∂h/∂m,
        S₀₀ = h₀Ch₀ᵀ, S₀₁ = h₀Ch₁ᵀ − h₀·c, S₁₁ = h₁Ch₁ᵀ − 2h₁·c + P_φφ.
        """
        Paa = self.Paa
        xa = self.xa
        lm = xa[3:].reshape(-1, 2)
        m = lm.shape[0]
        dx = lm[:, 0] - xa[0]
        dy = lm[:, 1] - xa[1]
        q = dx * dx + dy * dy
        r = np.sqrt(q)
        zhat = np.empty((m, 2))
        zhat[:, 0] = r
        zhat[:, 1] = wrap_angle(np.arctan2(dy, dx) - xa[2] + np.pi / 2)
        Hm = np.empty((m, 2, 2))
        Hm[:, 0, 0] = a0 = dx / r
        Hm[:, 0, 1] = a1 = dy / r
        Hm[:, 1, 0] = b0 = -dy / q
        Hm[:, 1, 1] = b1 = dx / q
        Hv = np.zeros((m, 2, 3))
        Hv[:, :, :2] = -Hm
        Hv[:, 1, 2] = -1.0
        d = 3 + 2 * np.arange(m)
        Pv = Paa[:3, 3:]
        c00 = Paa[d, d] - 2.0 * Pv[0, 0::2] + Paa[0, 0]
        c11 = Paa[d + 1, d + 1] - 2.0 * Pv[1, 1::2] + Paa[1, 1]
        c01 = Paa[d, d + 1] - Pv[0, 1::2] - Pv[1, 0::2] + Paa[0, 1]
        e0 = Pv[2, 0::2] - Paa[2, 0]
        e1 = Pv[2, 1::2] - Paa[2, 1]
        S = np.empty((m, 2, 2))
        S[:, 0, 0] = a0 * (c00 * a0 + c01 * a1) + a1 * (c01 * a0 + c11 * a1)
        S[:, 0, 1] = S[:, 1, 0] = a0 * (c00 * b0 + c01 * b1) + a1 * (c01 * b0 + c11 * b1) - (a0 * e0 + a1 * e1)
        S[:, 1, 1] = b0 * (c00 * b0 + c01 * b1) + b1 * (c01 * b0 + c11 * b1) - 2.0 * (b0 * e0 + b1 * e1) + Paa[2, 2]
        return lm, Hv, Hm, zhat, S

    def associate(self, z: np.ndarray) -> tuple[Association, tuple]:
        """Associate a scan ``z`` (n, 2) of (range, bearing eq. 5) against the active landmarks."""
        p = self.params
        pred = self._predicted()
        lm, _, _, zhat, S_state = pred
        a = associate(z, zhat, S_state, p.R, lm, gate=p.gate, new_gate=p.new_gate,
                      init_max_range=p.init_max_range, max_range=p.max_range, n_sigma=p.n_sigma,
                      sep_fraction=p.sep_fraction, min_separation=p.min_separation,
                      risk_fraction=p.risk_fraction)
        return a, pred

    def needs_global_update(self) -> bool:
        """True when the vehicle has left the local area (the next ``update`` starts a new phase)."""
        return bool(self.compressed and np.hypot(*(self.xa[:2] - self.center)) > self.params.local_exit)

    def update(self, z: np.ndarray, *, assoc: Association | None = None, init_new: bool = True,
               pred: tuple | None = None) -> Association:
        """One scan: (local-area check), association, joint EKF update, new (or tentative) landmarks.

        ``assoc``/``pred`` (from ``associate`` on this scan, nothing changed since) skip the
        association; they are ignored when the local area is left first (indices would change).
        """
        z = np.asarray(z, dtype=float).reshape(-1, 2)
        self.n_scans += 1
        if self.needs_global_update():
            self.global_update()
            assoc = pred = None
        if assoc is None:
            a, pred = self.associate(z)
        else:
            a, pred = assoc, (self._predicted() if pred is None else pred)
        ids = (self.a_idx[3 + 2 * a.lm] - 3) // 2    # active index → landmark number, before new ones join
        if a.obs.size:
            self.update_known(z[a.obs], a.lm, pred)
        n_before = self.n_landmarks
        mapped = self._new_features(z[a.new]) if init_new else np.zeros(0, dtype=int)
        if self.association_log is not None:
            self.association_log.append(ScanAssociation(
                self.n_scans, z[a.obs].copy(), ids.astype(int), z[a.new[mapped]].copy(),
                np.arange(n_before, n_before + mapped.size)))
        return a

    def update_known(self, z: np.ndarray, lm_local: np.ndarray, pred: tuple | None = None) -> None:
        """Joint EKF/CEKF update with observations z (k, 2) of active landmarks ``lm_local`` (distinct)."""
        z = np.asarray(z, dtype=float).reshape(-1, 2)
        lm_local = np.asarray(lm_local, dtype=int)
        k = lm_local.size
        if k == 0:
            return
        Paa = self.Paa
        _, Hv, Hm, zhat, _ = self._predicted() if pred is None else pred
        cols = np.concatenate([np.arange(3), (3 + 2 * lm_local[:, None] + np.arange(2)).ravel()])
        Hc = np.zeros((2 * k, 3 + 2 * k))
        r2 = np.arange(2 * k).reshape(k, 2)
        Hc[:, :3] = Hv[lm_local].reshape(2 * k, 3)
        Hc[r2[:, :, None], 3 + r2[:, None, :]] = Hm[lm_local]
        nu = z - zhat[lm_local]
        nu[:, 1] = wrap_angle(nu[:, 1])
        nu = nu.ravel()
        PHt = Paa[:, cols] @ Hc.T                       # P_AA H_aᵀ (n_A × 2k)
        S = Hc @ PHt[cols]
        S[r2[:, 0], r2[:, 0]] += self.params.sigma_r**2
        S[r2[:, 1], r2[:, 1]] += self.params.sigma_b**2
        cf = cho_factor(S, lower=True, check_finite=False)
        W = cho_solve(cf, PHt.T, check_finite=False)    # S⁻¹ H P (2k × n_A)
        if self.track:
            Hphi = Hc @ self._phi[cols]
            Sinv_Hphi = cho_solve(cf, Hphi, check_finite=False)
            self.psi += Hphi.T @ Sinv_Hphi
            self.theta += Sinv_Hphi.T @ nu
            self._phi -= PHt @ Sinv_Hphi
        self.xa += W.T @ nu
        self.xa[2] = wrap_angle(self.xa[2])
        Paa -= PHt @ W
        Paa += Paa.T
        Paa *= 0.5
        self._dirty = True

    def _new_features(self, z: np.ndarray) -> np.ndarray:
        """Unmapped observations: initialise at once (``min_obs`` = 1) or via tentative features.

        Returns the rows of ``z`` that became landmarks, in the order they were added. Beyond
        ``max_landmarks`` none does: the observation is counted (``n_refused_landmarks``) and dropped.
        """
        p = self.params
        if p.min_obs <= 1:
            rows = self._within_cap(np.arange(z.shape[0]))
            if rows.size:
                self.add_landmarks(z[rows])
            return rows
        # forget features not confirmed recently
        alive = self.n_scans - self._tent_last <= p.tentative_max_gap
        if not np.all(alive):
            self._tent, self._tent_cov = self._tent[alive], self._tent_cov[alive]
            self._tent_n, self._tent_last = self._tent_n[alive], self._tent_last[alive]
        q = z.shape[0]
        if q == 0:
            return np.zeros(0, dtype=int)
        pose = self.xa[:3]
        m = inverse_observe(pose, z)
        _, Gz = inverse_observe_jacobians(pose, z)
        C = Gz @ p.R @ np.swapaxes(Gz, -1, -2)
        match = np.full(q, -1)
        T = self._tent.shape[0]
        if T:
            d = m[:, None, :] - self._tent[None, :, :]
            S = C[:, None] + self._tent_cov[None]
            det = S[..., 0, 0] * S[..., 1, 1] - S[..., 0, 1] * S[..., 1, 0]
            d2 = (S[..., 1, 1] * d[..., 0] ** 2 - 2 * S[..., 0, 1] * d[..., 0] * d[..., 1]
                  + S[..., 0, 0] * d[..., 1] ** 2) / det
            used = np.zeros(T, bool)
            for flat in np.argsort(d2, axis=None):      # greedy, closest pairs first (few pairs)
                i, j = divmod(int(flat), T)
                if d2[i, j] >= p.tentative_gate:
                    break
                if match[i] < 0 and not used[j]:
                    match[i] = j
                    used[j] = True
        hit = match >= 0
        j = match[hit]
        self._tent[j], self._tent_cov[j] = m[hit], C[hit]
        self._tent_n[j] += 1
        self._tent_last[j] = self.n_scans
        promote = hit.copy()
        promote[hit] = self._tent_n[j] >= p.min_obs
        fresh = ~hit
        keep = np.ones(T, bool)
        keep[match[promote]] = False
        self._tent = np.concatenate([self._tent[keep], m[fresh]])
        self._tent_cov = np.concatenate([self._tent_cov[keep], C[fresh]])
        self._tent_n = np.concatenate([self._tent_n[keep], np.ones(int(fresh.sum()), int)])
        self._tent_last = np.concatenate([self._tent_last[keep], np.full(int(fresh.sum()), self.n_scans)])
        rows = self._within_cap(np.flatnonzero(promote))
        if rows.size:
            self.add_landmarks(z[rows])
        return rows

    def _within_cap(self, rows: np.ndarray) -> np.ndarray:
        """The first of ``rows`` that still fit under ``max_landmarks``; the rest are counted as refused."""
        room = max(0, self.params.max_landmarks - self.n_landmarks)
        self.n_refused_landmarks += max(0, rows.size - room)
        self._refused_untold += max(0, rows.size - room)
        return rows[:room]

    def take_refused_landmarks(self) -> int:
        """New landmarks refused by the map-size cap since the last call (for a node's refusal line)."""
        n, self._refused_untold = self._refused_untold, 0
        return n

    def add_landmarks(self, z: np.ndarray) -> None:
        """Landmark initialisation m = g(x_v, z) (inverse of eq. 5), joining A (see module docstring)."""
        z = np.asarray(z, dtype=float).reshape(-1, 2)
        q = z.shape[0]
        if q == 0:
            return
        Paa0 = self.Paa
        pose = self.xa[:3]
        m = inverse_observe(pose, z)
        Gv, Gz = inverse_observe_jacobians(pose, z)
        Gv = Gv.reshape(2 * q, 3)
        P_nA = Gv @ Paa0[:3, :]
        blk = Gz @ self.params.R @ np.swapaxes(Gz, -1, -2)
        P_nn = P_nA[:, :3] @ Gv.T
        idx = np.arange(2 * q).reshape(q, 2)
        P_nn[idx[:, :, None], idx[:, None, :]] += blk
        na = self.xa.size
        xa = np.concatenate([self.xa, m.ravel()])
        Paa = np.empty((na + 2 * q, na + 2 * q))
        Paa[:na, :na] = Paa0
        Paa[na:, :na] = P_nA
        Paa[:na, na:] = P_nA.T
        Paa[na:, na:] = 0.5 * (P_nn + P_nn.T)
        new_idx = np.arange(self._n_total, self._n_total + 2 * q)
        self._n_total += 2 * q
        self.a_idx = np.concatenate([self.a_idx, new_idx])
        self._dirty = True
        if self.track:
            self._phi = np.vstack([self._phi, Gv @ self._phi[:3]])
            self.xa, self._Paa = xa, Paa
        else:
            self.x, self._P = xa, Paa
            self.xa, self._Paa = self.x, self._P

    def fuse(self, h, cols: np.ndarray, z: np.ndarray, R: np.ndarray, *, angle_rows=(), iterations: int = 3) -> None:
        """Iterated EKF update of the full state with one observation z = h(X[cols]) + N(0, R).

        ``h(xs) -> (ẑ, H)`` with H = ∂h/∂X[cols]; rows in ``angle_rows`` are wrapped. Gauss–Newton
        relinearisation (``iterations``) around the updated mean. Performs a global update first
        (O(n²) per iteration; used for the rare PF → CEKF hand-over) and restarts the local area.
        """
        self.mean_cov()
        cols = np.asarray(cols, dtype=int)
        x0, P = self.x.copy(), self._P
        PHt_cols = None
        xi = x0.copy()
        for _ in range(max(1, iterations)):
            zhat, H = h(xi[cols])
            nu = np.asarray(z, dtype=float) - zhat - H @ (x0[cols] - xi[cols])
            for r in angle_rows:
                nu[r] = wrap_angle(nu[r])
            PHt_cols = P[:, cols] @ H.T
            S = H @ PHt_cols[cols] + R
            cf = cho_factor(S, lower=True, check_finite=False)
            xi = x0 + PHt_cols @ cho_solve(cf, nu, check_finite=False)
        self.x = xi
        self.x[2] = wrap_angle(self.x[2])
        P -= PHt_cols @ cho_solve(cf, PHt_cols.T, check_finite=False)
        P += P.T
        P *= 0.5
        self._clear_tentative()
        self._repartition()

    def set_vehicle(self, pose: np.ndarray, Pvv: np.ndarray, Pvm: np.ndarray) -> None:
        """Replace the vehicle mean, covariance and vehicle–map cross-covariance (3, 2L); restarts A.

        Tentative features are forgotten: they were placed with the replaced pose.
        """
        self.mean_cov()
        P = self._P
        self.x[:3] = pose
        P[:3, :3] = 0.5 * (Pvv + Pvv.T)
        P[:3, 3:] = Pvm
        P[3:, :3] = Pvm.T
        self._clear_tentative()
        self._repartition()
