"""Gaussian helpers: covariance checks, symmetrisation, Mahalanobis distances and σ-ellipses.

Every layer that receives a covariance from outside (a message, a parameter, a file) asks
``covariance_problem`` for a reason string instead of letting a Cholesky fail deep inside a
filter. Arrays may carry leading batch dimensions: ``(..., n, n)``.
"""

from __future__ import annotations

import numpy as np

# Relative tolerances: a covariance read from float64 messages is symmetric only to rounding.
SYMMETRY_RTOL = 1e-9
PSD_RTOL = 1e-9


class CovarianceError(ValueError):
    """A covariance is not finite, not square, not symmetric or not positive semi-definite."""


def symmetrize(P: np.ndarray) -> np.ndarray:
    """Return ½(P + Pᵀ) over the last two axes; removes rounding asymmetry after updates."""
    P = np.asarray(P, dtype=float)
    with np.errstate(over='ignore', invalid='ignore'):  # hostile 1e308 entries: inf, refused by the finite checks
        return 0.5 * (P + np.swapaxes(P, -1, -2))


def covariance_problem(P: np.ndarray, *, definite: bool = False) -> str | None:
    """Return why ``P`` is not a valid covariance, or ``None`` when it is.

    Checks, in order: shape (square), finite entries, symmetry (relative to the largest
    entry), and the smallest eigenvalue (≥ −tol·max|P|, or > tol·max|P| when ``definite``).
    """
    P = np.asarray(P, dtype=float)
    if P.ndim < 2 or P.shape[-1] != P.shape[-2]:
        return f'covariance must be square, got shape {P.shape}'
    if not np.all(np.isfinite(P)):
        return 'covariance has non-finite entries'
    scale = max(float(np.max(np.abs(P))) if P.size else 0.0, np.finfo(float).tiny)
    asym = float(np.max(np.abs(P - np.swapaxes(P, -1, -2)))) if P.size else 0.0
    if asym > SYMMETRY_RTOL * scale:
        return f'covariance is not symmetric (max |P-Pᵀ| = {asym:.3g})'
    eig_min = float(np.min(np.linalg.eigvalsh(symmetrize(P)))) if P.size else 0.0
    if definite and eig_min <= PSD_RTOL * scale:
        return f'covariance is not positive definite (smallest eigenvalue {eig_min:.3g})'
    if eig_min < -PSD_RTOL * scale:
        return f'covariance is not positive semi-definite (smallest eigenvalue {eig_min:.3g})'
    return None


def check_covariance(P: np.ndarray, name: str = 'covariance', *, definite: bool = False) -> np.ndarray:
    """Return ``P`` as a float array, or raise ``CovarianceError`` naming ``name`` and the reason."""
    reason = covariance_problem(P, definite=definite)
    if reason is not None:
        raise CovarianceError(f'{name}: {reason}')
    return np.asarray(P, dtype=float)


def mahalanobis_sq(d: np.ndarray, S: np.ndarray) -> np.ndarray:
    """dᵀ S⁻¹ d over leading batch dimensions, by a solve (never an explicit inverse)."""
    d = np.asarray(d, dtype=float)
    sol = np.linalg.solve(S, d[..., None])[..., 0]
    return np.einsum('...i,...i->...', d, sol)


def ellipse_points(mean: np.ndarray, cov: np.ndarray, n_sigma: float = 2.0, n_points: int = 72) -> np.ndarray:
    """Closed outlines (..., n_points + 1, 2) of {p : (p − μ)ᵀ R⁻¹ (p − μ) = n_sigma²}, last point = first.

    mean (..., 2), cov (..., 2, 2): one eigen-decomposition R = V Λ Vᵀ per Gaussian, batched, and
    p = μ + n_sigma V Λ^½ [cos θ, sin θ]; negative eigenvalues (rounding) are clipped, so a
    singular PSD R draws as a segment. No validation: callers with outside data check first.
    """
    mean = np.asarray(mean, dtype=float)
    w, V = np.linalg.eigh(symmetrize(np.asarray(cov, dtype=float)))
    theta = np.linspace(0.0, 2.0 * np.pi, n_points + 1)
    unit = np.stack([np.cos(theta), np.sin(theta)], axis=-1)              # (n_points + 1, 2)
    axes = V * np.sqrt(np.clip(w, 0.0, None))[..., None, :]               # columns scaled by σ
    pts = mean[..., None, :] + n_sigma * unit @ np.swapaxes(axes, -1, -2)
    pts[..., -1, :] = pts[..., 0, :]
    return pts
