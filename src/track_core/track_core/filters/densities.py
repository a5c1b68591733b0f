"""Batched Gaussian densities and a Cholesky factorisation that survives rounding.

Shapes: leading batch dimensions are allowed everywhere, ``d`` (..., n), ``S`` (..., n, n).
"""

from __future__ import annotations

import numpy as np

from track_core.filters.gaussian import symmetrize

_LOG_2PI = float(np.log(2.0 * np.pi))


def cholesky_jitter(P: np.ndarray, rel_floor: float = 1e-12) -> np.ndarray:
    """Lower Cholesky factor of a batch of PSD matrices.

    Tries ``np.linalg.cholesky`` first; if any matrix of the batch is only semi-definite (or
    slightly indefinite from rounding), the batch is rebuilt from its eigen-decomposition with
    eigenvalues floored at ``rel_floor``·max(eigenvalue, per matrix) and factorised again.
    """
    P = symmetrize(P)
    try:
        return np.linalg.cholesky(P)
    except np.linalg.LinAlgError:
        vals, vecs = np.linalg.eigh(P)
        top = np.max(np.abs(vals), axis=-1, keepdims=True)
        floor = np.maximum(rel_floor * top, np.finfo(float).tiny)
        vals = np.maximum(vals, floor)
        P_fix = symmetrize((vecs * vals[..., None, :]) @ np.swapaxes(vecs, -1, -2))
        return np.linalg.cholesky(P_fix)


def gaussian_logpdf(d: np.ndarray, S: np.ndarray | None = None, *, chol: np.ndarray | None = None) -> np.ndarray:
    """log N(d; 0, S) over leading batch dimensions; pass ``chol`` (lower factor of S) to reuse it."""
    d = np.asarray(d, dtype=float)
    L = cholesky_jitter(S) if chol is None else np.asarray(chol, dtype=float)
    L_b = np.broadcast_to(L, (*d.shape, d.shape[-1]))
    u = np.linalg.solve(L_b, d[..., None])[..., 0]  # L u = d; generic solve is batched and exact here
    log_det = 2.0 * np.sum(np.log(np.diagonal(L, axis1=-2, axis2=-1)), axis=-1)
    n = d.shape[-1]
    return -0.5 * (np.sum(u * u, axis=-1) + log_det + n * _LOG_2PI)
