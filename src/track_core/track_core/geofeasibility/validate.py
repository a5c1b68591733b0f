"""Shape handling and input checks shared by every score.

Pairs are given as μ1 (n, 2), R1 (n, 2, 2), μ2 (n, 2), R2 (n, 2, 2); any argument may also be
a single (2,) / (2, 2) that broadcasts over the batch. A covariance must be finite, symmetric
and positive definite, with the same relative tolerances as
:func:`track_core.filters.covariance_problem` (``SYMMETRY_RTOL``, ``PSD_RTOL``, both relative to
the largest entry of that pair's matrix). With ``PSD_RTOL = 1e-9`` this admits aspect ratios
r_x/r_y up to about 3·10⁴. A failure raises ``ValueError`` naming the first bad pair index,
the argument and the reason; a score is never silently 0 for bad input.
"""

from __future__ import annotations

import numpy as np

from track_core.filters.gaussian import PSD_RTOL, SYMMETRY_RTOL, covariance_problem


def _first_bad(bad: np.ndarray) -> tuple[int, int]:
    idx = np.flatnonzero(bad)
    return int(idx[0]), idx.size - 1


def _more(k: int) -> str:
    return f' (and {k} more bad pair{"s" if k > 1 else ""})' if k else ''


def _check_mean(mu: np.ndarray, name: str) -> None:
    # x + y is non-finite iff x or y is (inf − inf = nan): one pass instead of a reduction
    ok = np.isfinite(mu[:, 0] + mu[:, 1])
    if not ok.all():
        i, k = _first_bad(~ok)
        raise ValueError(f'pair {i}: {name} has non-finite entries {mu[i].tolist()}{_more(k)}')


def _check_cov(R: np.ndarray, name: str) -> np.ndarray:
    a, b, b2, c = np.ascontiguousarray(R.reshape(-1, 4).T)
    with np.errstate(invalid='ignore', over='ignore'):
        finite = np.isfinite(a + b + b2 + c)
        scale = np.maximum(np.maximum(np.abs(a), np.abs(c)), np.maximum(np.abs(b), np.abs(b2)))
        bs = 0.5 * (b + b2)
        half = 0.5 * (a - c)
        lam_max = 0.5 * (a + c) + np.sqrt(half * half + bs * bs)  # np.hypot is ~10x slower
        det = a * c - bs * bs
        # λ_min = det/λ_max (no cancellation); written as a product test to avoid dividing
        good = finite & (np.abs(b - b2) <= SYMMETRY_RTOL * scale) & (lam_max > 0) \
            & (det > PSD_RTOL * scale * lam_max)
    if not good.all():
        i, k = _first_bad(~good)
        reason = covariance_problem(R[i], definite=True) or (
            f'covariance is not positive definite (smallest eigenvalue {det[i] / lam_max[i]:.3g})')
        raise ValueError(f'pair {i}: {name} {reason}: {R[i].tolist()}{_more(k)}')
    out = np.empty_like(R)
    out[:, 0, 0], out[:, 1, 1] = a, c
    out[:, 0, 1] = out[:, 1, 0] = bs
    return out


def check_pairs(mu1, R1, mu2, R2) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, bool]:
    """Broadcast to (n, 2), (n, 2, 2), (n, 2), (n, 2, 2), check, symmetrise.

    Returns the four arrays and ``single`` (True when every input was a single pair, so the
    caller returns a 0-d result). Raises ``ValueError`` naming pair index, argument and reason.
    """
    arrs = [np.asarray(v, dtype=float) for v in (mu1, R1, mu2, R2)]
    for v, name, core in zip(arrs, ('mu1', 'R1', 'mu2', 'R2'), (1, 2, 1, 2), strict=True):
        if v.ndim not in (core, core + 1) or v.shape[-core:] != (2,) * core:
            want = '(2,) or (n, 2)' if core == 1 else '(2, 2) or (n, 2, 2)'
            raise ValueError(f'{name} must have shape {want}, got {v.shape}')
    single = all(v.ndim == core for v, core in zip(arrs, (1, 2, 1, 2), strict=True))
    sizes = {v.shape[0] for v, core in zip(arrs, (1, 2, 1, 2), strict=True) if v.ndim == core + 1}
    if len(sizes) > 1:
        raise ValueError(f'batch sizes differ: {sorted(sizes)}')
    n = sizes.pop() if sizes else 1
    m1, c1, m2, c2 = (np.ascontiguousarray(np.broadcast_to(v, (n, *(2,) * core)))
                      for v, core in zip(arrs, (1, 2, 1, 2), strict=True))
    _check_mean(m1, 'mu1')
    _check_mean(m2, 'mu2')
    c1 = _check_cov(c1, 'R1')
    c2 = _check_cov(c2, 'R2')
    return m1, c1, m2, c2, single
