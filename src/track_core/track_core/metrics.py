"""Track-quality metrics shared by summaries and experiments (truth vs estimate)."""

from __future__ import annotations

import numpy as np


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


def mean_nees(err: np.ndarray, P: np.ndarray) -> tuple[float, int]:
    """(average normalised estimation error squared errᵀP⁻¹err over the rows where it is defined,
    number of rows where it is not): a singular or non-finite P (``nees_or_nan``) never raises."""
    if not len(err):
        return float('nan'), 0
    v, _ = nees_or_nan(err, P)
    ok = np.isfinite(v)
    return (float(v[ok].mean()) if ok.any() else float('nan')), int((~ok).sum())


# A covariance whose smallest eigenvalue is below this share of its largest, or below SINGULAR_ATOL
# (m², (m/s)²: a collapsed cloud has all eigenvalues ~1e-30), is treated as singular.
SINGULAR_RTOL = 1e-12
SINGULAR_ATOL = 1e-12


def nees_or_nan(d: np.ndarray, S: np.ndarray) -> tuple[np.ndarray, list[str | None]]:
    """dᵀ S⁻¹ d per step for d (K, n), S (K, n, n), never raising.

    A step whose S is not finite or singular (λmin ≤ max(SINGULAR_RTOL·λmax, SINGULAR_ATOL), e.g. a
    collapsed particle cloud) gets NaN and a reason string; the others are solved in one batch.
    """
    d, S = np.asarray(d, dtype=float), np.asarray(S, dtype=float)
    out = np.full(d.shape[:-1], np.nan)
    reasons: list[str | None] = [None] * out.size
    finite = np.all(np.isfinite(S), axis=(-2, -1)) & np.all(np.isfinite(d), axis=-1)
    lam = np.zeros(d.shape)
    lam[finite] = np.linalg.eigvalsh(0.5 * (S[finite] + np.swapaxes(S[finite], -1, -2)))
    ok = finite & (lam[..., 0] > np.maximum(SINGULAR_RTOL * lam[..., -1], SINGULAR_ATOL))
    if ok.any():
        sol = np.linalg.solve(S[ok], d[ok][..., None])[..., 0]
        out[ok] = np.einsum('...i,...i->...', d[ok], sol)
    for i in np.flatnonzero(~ok.ravel()):
        reasons[i] = ('covariance or error not finite' if not finite.ravel()[i] else
                      f'covariance singular (smallest eigenvalue {lam.reshape(-1, d.shape[-1])[i, 0]:.3g}, '
                      f'largest {lam.reshape(-1, d.shape[-1])[i, -1]:.3g})')
    return out, reasons
