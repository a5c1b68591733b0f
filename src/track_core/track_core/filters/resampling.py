"""Particle resampling: log-weight normalisation, effective sample size, systematic resampling."""

from __future__ import annotations

import numpy as np


def normalize_log_weights(log_w: np.ndarray) -> tuple[np.ndarray, float]:
    """Return normalised weights from log-weights (max-shifted) and log Σ exp(log_w).

    Raises ``ValueError`` when no weight is finite (every particle impossible).
    """
    log_w = np.asarray(log_w, dtype=float)
    m = np.max(log_w)
    if not np.isfinite(m):
        raise ValueError('particle weights: no finite log-weight (all particles have zero likelihood)')
    w = np.exp(log_w - m)
    s = float(np.sum(w))
    return w / s, float(m + np.log(s))


def effective_sample_size(weights: np.ndarray) -> float:
    """ESS = 1 / Σ wᵢ² for normalised weights (N for uniform weights, 1 for a single particle)."""
    w = np.asarray(weights, dtype=float)
    return float(1.0 / np.sum(w**2))


def systematic_resample(weights: np.ndarray, rng: np.random.Generator, n: int | None = None) -> np.ndarray:
    """Indices of ``n`` particles (default N = len(weights)) drawn by systematic resampling (one uniform,
    ``n`` strata).

    ``weights`` must be normalised (sum 1); the count of index i is ⌊n wᵢ⌋ or ⌈n wᵢ⌉.
    """
    w = np.asarray(weights, dtype=float)
    n = w.size if n is None else int(n)
    positions = (rng.random() + np.arange(n)) / n
    cum = np.cumsum(w)
    cum[-1] = 1.0  # guard against rounding in the last bin
    return np.searchsorted(cum, positions, side='right').clip(0, w.size - 1)
