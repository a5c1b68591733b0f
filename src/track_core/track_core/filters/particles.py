"""Particle statistics: weighted mean and covariance of a particle set."""

from __future__ import annotations

import numpy as np

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
