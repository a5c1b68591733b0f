"""De-correlated map (eqs. 10–11), helix initialisation (eqs. 12–13) and SIR localisation (§2.1).

Re-referencing (§3.1, eq. 10): origin b₁, x axis towards b₂ (γ = atan2(b₂ − b₁)); a point m becomes
Rᵀ(γ)(m − b₁), a pose (p, φ) becomes (Rᵀ(γ)(p − b₁), φ − γ); covariances through the exact
Jacobian, so the common translation/rotation error disappears.

Bound (eq. 11): p̃ᵢ = pᵢ + Σⱼ |kᵢⱼ Cᵢⱼ|, kᵢⱼ = 1/kⱼᵢ > 0. For 2×2 blocks we read |kᵢⱼ Cᵢⱼ| as
kᵢⱼ·(Cᵢⱼ Cᵢⱼᵀ)^½ (the partner block kⱼᵢ·(Cᵢⱼᵀ Cᵢⱼ)^½), a guaranteed bound: for every pair
[[k U Σ Uᵀ, −C], [−Cᵀ, V Σ Vᵀ / k]] = [√k U; −V/√k] Σ [·]ᵀ ⪰ 0 (tested). We use kᵢⱼ = 1.

Likelihood (eq. 9, documented approximation): association-free over the map's Gaussian landmarks
N(m̂ⱼ, p̃ⱼ) plus a uniform clutter density c: p(z|x) = Πₒ [c + Σⱼ pⱼ(zₒ | x)]; landmarks in view
but unobserved carry no information.
- ``log_likelihood`` (used), in the map plane: wₒ(x) = p + zᵣ (cos θ, sin θ), θ = φ + z_β − π/2,
  pⱼ = zᵣ · N(wₒ; m̂ⱼ, p̃ⱼ + J R Jᵀ) (J = ∂w/∂z, |det J| = zᵣ), over the landmarks within ``n_sigma``
  of wₒ (at most ``k_max``, a k-d tree per map): O(N·o·k_max·log c).
- ``log_likelihood_dense`` (reference, tested equal to first order): pⱼ = N(zₒ; h(x, m̂ⱼ),
  Hₘp̃ⱼHₘᵀ + R) over every landmark.

Helix (eqs. 12–13): per (observation, landmark) pair x = xᵢ + z_r cos τ, y = yᵢ + z_r sin τ,
φ = τ − z_β − π/2, z_r, z_β, xᵢ, yᵢ perturbed by their noises (eq. 13); τ within φ̂ ± n_sigma σ_φ of
the CEKF heading, particles outside the CEKF position gate (χ²₂ 99.9 %) rejected (§3.1); none left:
the prior Gaussian is sampled. Convergence (§3.1): the weighted stds of x, y and φ all below twice
the propagation noise, here the per-scan roughening ``jitter``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from track_core.filters import (
    cholesky_jitter,
    circular_mean,
    gaussian_logpdf,
    mahalanobis_sq,
    normalize_log_weights,
    systematic_resample,
    weighted_mean_cov,
    wrap_angle,
)
from track_core.slam.models import InputModel, observe, observe_jacobians, vehicle_step


def _rot(g: float) -> np.ndarray:
    c, s = np.cos(g), np.sin(g)
    return np.array([[c, -s], [s, c]])


def rereference(pose: np.ndarray, lm: np.ndarray, P: np.ndarray, base: tuple[int, int]):
    """Express (pose, landmarks) in the frame of landmarks ``base`` = (i, j) (eq. 10).

    ``P`` is the joint covariance of [pose (3), lm (2c)]. Returns (pose_l, lm_l, P_l, J) with
    P_l = J P Jᵀ, J the Jacobian of the transformation.
    """
    lm = np.asarray(lm, dtype=float).reshape(-1, 2)
    c = lm.shape[0]
    i, j = base
    b1, b2 = lm[i], lm[j]
    d = b2 - b1
    g = float(np.arctan2(d[1], d[0]))
    Rt = _rot(g).T
    pts = np.vstack([pose[None, :2], lm])          # (1 + c, 2)
    loc = (pts - b1) @ Rt.T
    dg = np.array([-d[1], d[0]]) / (d @ d)         # ∂γ/∂b₂ (= −∂γ/∂b₁)
    n = 3 + 2 * c
    J = np.zeros((n, n))
    own = np.concatenate([[0], 3 + 2 * np.arange(c)])[:, None] + np.arange(2)   # (1 + c, 2) state rows
    cols_b1 = 3 + 2 * i + np.arange(2)
    cols_b2 = 3 + 2 * j + np.arange(2)
    G = np.stack([loc[:, 1], -loc[:, 0]], axis=1)[:, :, None] * dg               # ∂l/∂γ ⊗ ∂γ/∂b₂, (1 + c, 2, 2)
    rr = own[:, :, None]
    J[rr, own[:, None, :]] = Rt                    # each point's own block first (b₁'s then gains the terms below)
    J[rr, cols_b1] += -Rt - G
    J[rr, cols_b2] += G
    J[2, 2] = 1.0
    J[2, cols_b1] = dg
    J[2, cols_b2] = -dg
    pose_l = np.array([loc[0, 0], loc[0, 1], wrap_angle(pose[2] - g)])
    return pose_l, loc[1:], J @ P @ J.T, J


def from_base_frame(poses_l: np.ndarray, b1: np.ndarray, b2: np.ndarray) -> np.ndarray:
    """Poses (N, 3) in the frame of base landmarks b₁, b₂ → global poses (N, 3): inverse of eq. 10."""
    d = b2 - b1
    g = float(np.arctan2(d[1], d[0]))
    c, s = np.cos(g), np.sin(g)
    out = np.empty_like(poses_l)
    out[:, 0] = b1[0] + c * poses_l[:, 0] - s * poses_l[:, 1]
    out[:, 1] = b1[1] + s * poses_l[:, 0] + c * poses_l[:, 1]
    out[:, 2] = wrap_angle(poses_l[:, 2] + g)
    return out


def to_global(pose_l: np.ndarray, b1: np.ndarray, b2: np.ndarray):
    """Pose in the base frame → global pose (``from_base_frame``), with Jacobians wrt [b₁, b₂] (3×4)
    and pose_l (3×3)."""
    d = b2 - b1
    g = float(np.arctan2(d[1], d[0]))
    R = _rot(g)
    pose = from_base_frame(np.asarray(pose_l, dtype=float)[None], b1, b2)[0]
    p = pose[:2]
    dg = np.array([-d[1], d[0]]) / (d @ d)
    w = p - b1                                      # ∂(R l)/∂γ = [−w_y, w_x]
    dR = np.array([-w[1], w[0]])
    Gb = np.zeros((3, 4))
    Gb[:2, :2] = np.eye(2) - np.outer(dR, dg)
    Gb[:2, 2:] = np.outer(dR, dg)
    Gb[2, :2] = -dg
    Gb[2, 2:] = dg
    Gl = np.eye(3)
    Gl[:2, :2] = R
    return pose, Gb, Gl


def base_frame_pose(pose: np.ndarray, b1: np.ndarray, b2: np.ndarray):
    """Global pose → pose in the base frame (eq. 10), with Jacobians wrt the pose (3×3) and [b₁, b₂] (3×4)."""
    d = b2 - b1
    g = float(np.arctan2(d[1], d[0]))
    Rt = _rot(g).T
    loc = Rt @ (pose[:2] - b1)
    dg = np.array([-d[1], d[0]]) / (d @ d)          # ∂γ/∂b₂ (= −∂γ/∂b₁)
    dl_dg = np.array([loc[1], -loc[0]])
    Jv = np.eye(3)
    Jv[:2, :2] = Rt
    Jb = np.zeros((3, 4))
    Jb[:2, :2] = -Rt - np.outer(dl_dg, dg)
    Jb[:2, 2:] = np.outer(dl_dg, dg)
    Jb[2, :2] = dg
    Jb[2, 2:] = -dg
    return np.array([loc[0], loc[1], wrap_angle(pose[2] - g)]), Jv, Jb


def decorrelate_blocks(P_map: np.ndarray, k: np.ndarray | None = None) -> np.ndarray:
    """Block-diagonal conservative bound of a landmark covariance (eq. 11): (c, 2, 2) blocks.

    ``k`` (c, c) with kᵢⱼ = 1/kⱼᵢ > 0 (default all ones). Vectorised over pairs (batched SVD).
    """
    c = P_map.shape[0] // 2
    B = P_map.reshape(c, 2, c, 2).transpose(0, 2, 1, 3)       # B[i, j] = C_ij
    U, s, _ = np.linalg.svd(B)
    absC = (U * s[..., None, :]) @ np.swapaxes(U, -1, -2)     # (C Cᵀ)^½
    if k is None:
        k = np.ones((c, c))
    else:
        k = np.asarray(k, dtype=float)
        if np.any(k <= 0) or not np.allclose(k * k.T, 1.0):
            raise ValueError('k: need k_ij > 0 and k_ij = 1/k_ji')
    off = ~np.eye(c, dtype=bool)
    return B[np.arange(c), np.arange(c)] + np.einsum('ij,ijkl->ikl', k * off, absC)


def block_diag_dense(blocks: np.ndarray) -> np.ndarray:
    """Dense block-diagonal matrix from (c, 2, 2) blocks."""
    c = blocks.shape[0]
    out = np.zeros((2 * c, 2 * c))
    idx = np.arange(2 * c).reshape(c, 2)
    out[idx[:, :, None], idx[:, None, :]] = blocks
    return out


@dataclass(frozen=True)
class PFParams:
    """SIR localisation settings (§2.1, §3.1)."""

    n_particles: int = 3000
    oversample: int = 4
    jitter: tuple[float, float, float] = (0.2, 0.2, np.deg2rad(0.5))  # per-scan propagation noise
    sigma_v: float = 0.5                 # σ of the first input (speed) [m/s]
    sigma_steer: float = np.deg2rad(3.0)  # σ of the second input: steering [rad] (ACFR) or yaw rate [rad/s]
    sigma_r: float = 0.5
    sigma_b: float = np.deg2rad(1.0)
    clutter: float = 1e-4            # uniform density of spurious returns [1/(m·rad)]
    heading_sigmas: float = 3.0      # τ window: φ̂ ± heading_sigmas·σ_φ
    prior_gate: float = 13.8         # χ²₂ 99.9 % on the CEKF position

    def __post_init__(self) -> None:
        if self.n_particles < 10:
            raise ValueError(f'n_particles = {self.n_particles}: must be >= 10')
        if self.oversample < 1:
            raise ValueError(f'oversample = {self.oversample}: must be >= 1')
        if min(self.jitter) <= 0:
            raise ValueError(f'jitter = {self.jitter}: every entry must be > 0')


def helix_particles(z: np.ndarray, lm: np.ndarray, lm_cov: np.ndarray, prior_mean: np.ndarray,
                    prior_cov: np.ndarray, n: int, rng: np.random.Generator, params: PFParams = PFParams()):
    """Samples of the helix family (eqs. 12–13) for every observation × landmark, gated by the prior.

    ``lm_cov``: (2, 2) or per-landmark (c, 2, 2) position covariance (the γ_x, γ_y of eq. 13).
    """
    z = np.asarray(z, dtype=float).reshape(-1, 2)
    lm = np.asarray(lm, dtype=float).reshape(-1, 2)
    lm_cov = np.broadcast_to(lm_cov, (lm.shape[0], 2, 2))
    nf = z.shape[0] * lm.shape[0]
    if nf == 0:
        return rng.multivariate_normal(prior_mean, prior_cov, size=n)
    per = max(1, int(np.ceil(params.oversample * n / nf)))
    oi, li = np.meshgrid(np.arange(z.shape[0]), np.arange(lm.shape[0]), indexing='ij')
    oi, li = np.repeat(oi.ravel(), per), np.repeat(li.ravel(), per)
    m = oi.size
    zr = z[oi, 0] + params.sigma_r * rng.standard_normal(m)
    zb = z[oi, 1] + params.sigma_b * rng.standard_normal(m)
    Lc = np.linalg.cholesky(lm_cov + 1e-12 * np.eye(2))
    mi = lm[li] + np.einsum('nij,nj->ni', Lc[li], rng.standard_normal((m, 2)))
    half = params.heading_sigmas * np.sqrt(prior_cov[2, 2])
    if half < np.pi:
        tau = prior_mean[2] + zb + np.pi / 2 + rng.uniform(-half, half, m)
    else:
        tau = rng.uniform(0.0, 2 * np.pi, m)
    parts = np.stack([mi[:, 0] + zr * np.cos(tau), mi[:, 1] + zr * np.sin(tau),
                      wrap_angle(tau - zb - np.pi / 2)], axis=1)
    keep = parts[mahalanobis_sq(parts[:, :2] - prior_mean[:2], prior_cov[:2, :2]) < params.prior_gate]
    if keep.shape[0] == 0:
        return rng.multivariate_normal(prior_mean, prior_cov, size=n)
    pick = rng.choice(keep.shape[0], size=n, replace=keep.shape[0] < n)
    return keep[pick]


def log_likelihood(particles: np.ndarray, z: np.ndarray, lm: np.ndarray, lm_cov: np.ndarray,
                   params: PFParams = PFParams(), *, tree: cKDTree | None = None, k_max: int = 8,
                   n_sigma: float = 5.0) -> np.ndarray:
    """Association-free log p(z | m, x) per particle, map-plane form (eq. 9, module docstring).

    ``lm_cov`` (c, 2, 2) or (2, 2); ``tree`` an optional ``cKDTree(lm)`` (built here if omitted).
    """
    z = np.asarray(z, dtype=float).reshape(-1, 2)
    lm = np.asarray(lm, dtype=float).reshape(-1, 2)
    n, o, c = particles.shape[0], z.shape[0], lm.shape[0]
    if o == 0 or c == 0:
        return np.zeros(n)
    lm_cov = np.broadcast_to(lm_cov, (c, 2, 2))
    th = particles[:, 2, None] + (z[None, :, 1] - np.pi / 2)            # (N, o)
    ct, st = np.cos(th), np.sin(th)
    r = z[:, 0]
    wx = (particles[:, 0, None] + r * ct).ravel()
    wy = (particles[:, 1, None] + r * st).ravel()
    vr = params.sigma_r**2
    vb = (r * params.sigma_b) ** 2
    q00 = (vr * ct * ct + vb * st * st).ravel()
    q11 = (vr * st * st + vb * ct * ct).ravel()
    q01 = ((vr - vb) * ct * st).ravel()
    a, b, d = lm_cov[:, 0, 0], lm_cov[:, 0, 1], lm_cov[:, 1, 1]
    lam = float(np.max(0.5 * (a + d) + np.sqrt(0.25 * (a - d) ** 2 + b * b)))
    bound = n_sigma * np.sqrt(lam + max(vr, float(vb.max())))
    k = min(k_max, c)
    tree = cKDTree(lm) if tree is None else tree
    _, jj = tree.query(np.stack([wx, wy], axis=1), k=k, distance_upper_bound=bound)
    jj = jj.reshape(-1, k)
    valid = jj < c
    jj = np.where(valid, jj, 0)
    ex = wx[:, None] - lm[jj, 0]
    ey = wy[:, None] - lm[jj, 1]
    s00 = q00[:, None] + a[jj]
    s01 = q01[:, None] + b[jj]
    s11 = q11[:, None] + d[jj]
    det = s00 * s11 - s01 * s01
    m2 = (s11 * ex * ex - 2.0 * s01 * ex * ey + s00 * ey * ey) / det
    dens = np.where(valid, np.exp(-0.5 * m2) / (2 * np.pi * np.sqrt(det)), 0.0).sum(axis=1)
    dens = dens.reshape(n, o) * r
    return np.sum(np.log(params.clutter + dens), axis=1)


def log_likelihood_dense(particles: np.ndarray, z: np.ndarray, lm: np.ndarray, lm_cov: np.ndarray,
                         params: PFParams = PFParams()) -> np.ndarray:
    """Reference: measurement-space form over every landmark (eq. 9 approximation, module docstring)."""
    z = np.asarray(z, dtype=float).reshape(-1, 2)
    if z.shape[0] == 0 or lm.shape[0] == 0:
        return np.zeros(particles.shape[0])
    zhat = observe(particles[:, None, :], lm[None, :, :])               # (N, c, 2)
    _, Hm = observe_jacobians(particles[:, None, :], lm[None, :, :])    # (N, c, 2, 2)
    S = Hm @ lm_cov[None] @ np.swapaxes(Hm, -1, -2) + np.diag([params.sigma_r**2, params.sigma_b**2])
    nu = z[None, :, None, :] - zhat[:, None, :, :]                       # (N, o, c, 2)
    nu[..., 1] = wrap_angle(nu[..., 1])
    dens = np.exp(gaussian_logpdf(nu, chol=cholesky_jitter(S)[:, None]))  # (N, o, c)
    return np.sum(np.log(params.clutter + dens.sum(axis=2)), axis=1)


class ParticleLocaliser:
    """SIR filter (§2.1) on a fixed de-correlated map, in the base-landmark frame."""

    def __init__(self, lm: np.ndarray, lm_cov: np.ndarray, params: PFParams,
                 vehicle: InputModel, rng: np.random.Generator) -> None:
        self.lm = np.asarray(lm, dtype=float)
        self.lm_cov = np.asarray(lm_cov, dtype=float)
        self.params = params
        self.vehicle = vehicle
        self.rng = rng
        self.particles = np.zeros((0, 3))
        self.weights = np.zeros(0)
        self.n_scans = 0
        self.tree = cKDTree(self.lm) if self.lm.shape[0] else None

    def initialise(self, z: np.ndarray, prior_mean: np.ndarray, prior_cov: np.ndarray) -> None:
        """Helix initialisation from every observation of the scan and every landmark (eqs. 12–13)."""
        n = self.params.n_particles
        self.particles = helix_particles(z, self.lm, self.lm_cov, prior_mean, prior_cov, n, self.rng, self.params)
        self.weights = np.full(n, 1.0 / n)

    def predict(self, u: np.ndarray, dt: float, Su: np.ndarray | None = None) -> None:
        """Propagate every particle with its own input-noise draw (vectorised): N(0, ``Su``) when a 2×2
        input covariance is given (an odometry twist covariance), else diag(``sigma_v``², ``sigma_steer``²)."""
        if dt <= 0 or self.particles.shape[0] == 0:
            return
        n = self.particles.shape[0]
        if Su is None:
            noise = self.rng.standard_normal((n, 2)) * [self.params.sigma_v, self.params.sigma_steer]
        else:
            noise = self.rng.standard_normal((n, 2)) @ cholesky_jitter(np.asarray(Su, dtype=float)).T
        un = np.asarray(u, dtype=float) + noise
        self.particles = vehicle_step(self.particles, un, dt, self.vehicle)

    def update(self, z: np.ndarray) -> bool:
        """Weight (eq. 3), convergence test (§3.1), systematic resampling + roughening. True = converged."""
        self.n_scans += 1
        ll = log_likelihood(self.particles, z, self.lm, self.lm_cov, self.params, tree=self.tree)
        w, _ = normalize_log_weights(np.log(self.weights) + ll)
        self.weights = w
        mean, cov = self.estimate()
        std = np.sqrt(np.diag(cov))
        converged = bool(np.all(std < 2.0 * np.asarray(self.params.jitter)))
        idx = systematic_resample(w, self.rng)
        p = self.particles[idx] + self.rng.standard_normal(self.particles.shape) * self.params.jitter
        p[:, 2] = wrap_angle(p[:, 2])
        self.particles = p
        self.weights = np.full(p.shape[0], 1.0 / p.shape[0])
        self._last = (mean, cov)
        return converged

    def estimate(self) -> tuple[np.ndarray, np.ndarray]:
        """Weighted mean (circular for φ) and covariance of the particles."""
        mean, cov = weighted_mean_cov(self.particles, self.weights)
        mean[2] = circular_mean(self.particles[:, 2], self.weights)
        d = wrap_angle(self.particles[:, 2] - mean[2])
        dd = self.particles[:, :2] - mean[:2]
        cov[2, 2] = float(self.weights @ (d * d))
        cov[:2, 2] = cov[2, :2] = self.weights @ (dd * d[:, None])
        return mean, cov
