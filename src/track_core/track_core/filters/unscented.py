"""Scaled unscented transform, vectorised over a batch of Gaussians (e.g. one per particle).

Shapes: means (..., n), covariances (..., n, n), sigma points (..., 2n+1, n); the leading
batch axes are typically the N particles of a particle filter, so one call updates all of them.

Weights follow the scaled UT (Julier 2002; van der Merwe 2000), λ = α²(n + κ) − n:
wᵐ₀ = λ/(n+λ), wᶜ₀ = λ/(n+λ) + (1 − α² + β), wᵐᵢ = wᶜᵢ = 1/(2(n+λ)), i = 1…2n.
(The sonar paper's Algorithm 2 prints the covariance weight ω₀ᶜ for the mean as well; with the
standard choice the predicted measurement is the UT mean and the linear case is exactly Kalman.)
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from track_core.filters.densities import cholesky_jitter
from track_core.filters.gaussian import symmetrize

Residual = Callable[[np.ndarray, np.ndarray], np.ndarray]


def _subtract(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a - b


@dataclass(frozen=True)
class UnscentedWeights:
    """Sigma-point weights and spread γ = √(n+λ) for dimension ``n``."""

    n: int
    wm: np.ndarray
    wc: np.ndarray
    gamma: float


def unscented_weights(n: int, alpha: float = 1.0, beta: float = 2.0, kappa: float = 0.0) -> UnscentedWeights:
    """Scaled-UT weights; raises ``ValueError`` if n < 1, α ≤ 0 or n + λ ≤ 0."""
    if n < 1:
        raise ValueError(f'unscented n must be >= 1, got {n}')
    if not alpha > 0:
        raise ValueError(f'unscented alpha must be > 0, got {alpha}')
    lam = alpha**2 * (n + kappa) - n
    if not n + lam > 0:
        raise ValueError(f'unscented kappa: n + lambda must be > 0, got {n + lam} (alpha={alpha}, kappa={kappa})')
    wm = np.full(2 * n + 1, 0.5 / (n + lam))
    wc = wm.copy()
    wm[0] = lam / (n + lam)
    wc[0] = lam / (n + lam) + (1.0 - alpha**2 + beta)
    return UnscentedWeights(n=n, wm=wm, wc=wc, gamma=float(np.sqrt(n + lam)))


def sigma_points(mean: np.ndarray, cov: np.ndarray, w: UnscentedWeights) -> np.ndarray:
    """χ₀ = μ, χᵢ = μ + γ Lᵢ, χₙ₊ᵢ = μ − γ Lᵢ with L the (jittered) Cholesky factor: (..., 2n+1, n)."""
    mean = np.asarray(mean, dtype=float)
    L = cholesky_jitter(cov)  # (..., n, n); column i is the i-th direction
    cols = w.gamma * np.swapaxes(L, -1, -2)  # (..., n, n), row i = γ Lᵢ
    mu = mean[..., None, :]
    return np.concatenate([mu, mu + cols, mu - cols], axis=-2)


def unscented_update(
    mean: np.ndarray,
    cov: np.ndarray,
    z: np.ndarray,
    h: Callable[[np.ndarray], np.ndarray],
    R: np.ndarray,
    w: UnscentedWeights,
    residual: Residual = _subtract,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Unscented measurement update of a batch of Gaussians N(mean, cov) with z = h(x) + v, v ~ N(0, R).

    ``h`` maps sigma points (..., 2n+1, n) to measurements (..., 2n+1, m). ``residual(a, b)``
    returns a − b, wrapping angular components (default: plain subtraction). The predicted
    measurement is formed as ẑ = Z₀ + Σ wᵐᵢ residual(Zᵢ, Z₀), so a bearing near ±π averages
    correctly. Returns the posterior (mean, cov), the innovation ν = residual(z, ẑ) and its
    covariance S = P_u + R. The gain is K = P_c S⁻¹ by a solve; P⁺ = P − K S Kᵀ.
    """
    mean = np.asarray(mean, dtype=float)
    chi = sigma_points(mean, cov, w)
    Z = h(chi)
    dZ0 = residual(Z, Z[..., :1, :])
    z_hat = Z[..., 0, :] + np.einsum('i,...im->...m', w.wm, dZ0)
    dZ = residual(Z, z_hat[..., None, :])
    dX = chi - mean[..., None, :]
    S = symmetrize(np.einsum('i,...ia,...ib->...ab', w.wc, dZ, dZ) + R)
    Pxz = np.einsum('i,...ia,...ib->...ab', w.wc, dX, dZ)
    K = np.swapaxes(np.linalg.solve(S, np.swapaxes(Pxz, -1, -2)), -1, -2)
    nu = residual(np.broadcast_to(np.asarray(z, dtype=float), z_hat.shape), z_hat)
    x_post = mean + np.einsum('...ij,...j->...i', K, nu)
    P_post = symmetrize(cov - K @ S @ np.swapaxes(K, -1, -2))
    return x_post, P_post, nu, S


def unscented_predict(
    mean: np.ndarray,
    cov: np.ndarray,
    f: Callable[[np.ndarray], np.ndarray],
    Q: np.ndarray,
    w: UnscentedWeights,
) -> tuple[np.ndarray, np.ndarray]:
    """Unscented prediction of a batch of Gaussians through x' = f(x) + q, q ~ N(0, Q).

    ``f`` maps sigma points (..., 2n+1, n) to (..., 2n+1, n) (a batch of states; the caller flattens the
    leading axes if its function takes (N, n)). Returns the predicted (mean, cov); for a linear
    f(x) = F x it is exactly (F μ, F P Fᵀ + Q).
    """
    chi = sigma_points(mean, cov, w)
    Y = f(chi)
    mu = np.einsum('i,...ia->...a', w.wm, Y)
    dY = Y - mu[..., None, :]
    return mu, symmetrize(np.einsum('i,...ia,...ib->...ab', w.wc, dY, dY) + Q)
