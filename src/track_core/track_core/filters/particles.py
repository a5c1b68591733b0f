"""Particle statistics: weighted moments of a particle set or a Gaussian mixture, and its bimodality."""

from __future__ import annotations

import numpy as np

from track_core.filters.densities import cholesky_jitter
from track_core.filters.gaussian import symmetrize


def weighted_mean_cov(x: np.ndarray, weights: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Mean Σ wᵢ xᵢ and covariance Σ wᵢ (xᵢ − x̄)(xᵢ − x̄)ᵀ of particles ``x`` (N, n).

    Uniform weights when ``weights`` is None; this is the 1/N (not 1/(N−1)) form used as the
    particle-filter output (e.g. the sonar paper's Algorithm 1 output step).
    """
    x = np.asarray(x, dtype=float)
    n = x.shape[0]
    w = np.full(n, 1.0 / n) if weights is None else np.asarray(weights, dtype=float) / np.sum(weights)
    mean = w @ x
    d = x - mean
    cov = np.einsum('i,ij,ik->jk', w, d, d)
    return mean, symmetrize(cov)


def mixture_mean_cov(m: np.ndarray, P: np.ndarray, weights: np.ndarray | None = None
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Moment matching of the Gaussian mixture Σ wⁱ N(mⁱ, Pⁱ): its mean and covariance.

    Cov = Σ wⁱ Pⁱ (within) + Σ wⁱ (mⁱ − m̄)(mⁱ − m̄)ᵀ (between); uniform weights when None.
    """
    mean, between = weighted_mean_cov(m, weights)
    w = np.full(m.shape[0], 1.0 / m.shape[0]) if weights is None else np.asarray(weights, float) / np.sum(weights)
    return mean, symmetrize(between + np.einsum('n,nij->ij', w, P))


def bimodality_coefficient(x: np.ndarray, weights: np.ndarray | None = None) -> float:
    """Sarle's bimodality coefficient b = (γ² + 1)/κ of the particles projected on their principal axis.

    γ is the weighted skewness and κ the (non-excess) kurtosis of the projection. b = 1/3 for a
    Gaussian, 5/9 for a uniform density; b > 5/9 suggests two modes, and two equal point masses give 1.
    ``x`` (N, n); NaN when the particles do not spread (zero variance).
    """
    x = np.asarray(x, dtype=float)
    mean, cov = weighted_mean_cov(x, weights)
    w = np.full(x.shape[0], 1.0 / x.shape[0]) if weights is None else np.asarray(weights, float) / np.sum(weights)
    axis = np.linalg.eigh(cov)[1][:, -1]
    u = (x - mean) @ axis
    var = float(w @ u**2)
    if not var > 0:
        return float('nan')
    skew = float(w @ u**3) / var**1.5
    kurt = float(w @ u**4) / var**2
    return (skew**2 + 1.0) / kurt


def liu_west_move(x: np.ndarray, rng: np.random.Generator, mean: np.ndarray | None = None,
                  cov: np.ndarray | None = None) -> np.ndarray:
    """The Liu–West shrinkage move of equally weighted samples ``x`` (N, n): x ← a x + (1 − a) x̄ + h L e.

    h = (4 / (N (n + 2)))^{1/(n + 4)} is Silverman's bandwidth, a = √(1 − h²) and L Lᵀ the samples'
    covariance (``mean``/``cov`` when the caller has them), so the moved cloud keeps the samples' mean and
    covariance while resampled duplicates are spread apart again (Liu & West 2001).
    """
    n_s, dim = x.shape
    h = (4.0 / (n_s * (dim + 2))) ** (1.0 / (dim + 4))
    a = np.sqrt(1.0 - h**2)
    if mean is None or cov is None:
        mean, cov = weighted_mean_cov(x)
    return a * x + (1 - a) * mean + h * rng.standard_normal((n_s, dim)) @ cholesky_jitter(cov).T
