"""Track-quality metrics shared by summaries and experiments (truth vs estimate)."""

from __future__ import annotations

import numpy as np

from track_core.filters.gaussian import mahalanobis_sq


def match_stamps(t_truth: np.ndarray, t_est: np.ndarray, tol: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
    """Indices (i_truth, i_est) of estimate stamps that have a truth stamp within ``tol`` seconds."""
    t_truth = np.asarray(t_truth, dtype=float)
    t_est = np.asarray(t_est, dtype=float)
    if t_truth.size == 0 or t_est.size == 0:
        return np.zeros(0, int), np.zeros(0, int)
    order = np.argsort(t_truth)
    pos = np.clip(np.searchsorted(t_truth[order], t_est), 1, t_truth.size - 1) if t_truth.size > 1 else \
        np.zeros(t_est.size, int)
    left = order[np.maximum(pos - 1, 0)]
    right = order[pos]
    nearest = np.where(np.abs(t_truth[left] - t_est) <= np.abs(t_truth[right] - t_est), left, right)
    ok = np.abs(t_truth[nearest] - t_est) <= tol
    return nearest[ok], np.flatnonzero(ok)


def rms(err: np.ndarray) -> float:
    """Root mean square of the Euclidean norm of the rows of ``err`` (shape (n, d))."""
    err = np.asarray(err, dtype=float)
    return float(np.sqrt(np.mean(np.sum(err**2, axis=-1)))) if err.size else float('nan')


def mean_nees(err: np.ndarray, P: np.ndarray) -> float:
    """Average normalised estimation error squared, errᵀP⁻¹err, over the rows."""
    return float(np.mean(mahalanobis_sq(err, P))) if len(err) else float('nan')
