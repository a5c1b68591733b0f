"""Geofeasibility scores of pairs of 2σ ellipses, batched: ``score(mu1, R1, mu2, R2, method)``.

Methods (n pairs at once; no Python loop over pairs):

- ``"mc"``: eq. 55, importance sampling from the Gaussian of the smaller-area ellipse S_min with
  N = ``n_samples`` draws per pair, independent between pairs:
  g_M = Σ 1[x ∈ S1 ∩ S2]/p(x) / Σ 1[x ∈ S_min]/p(x). Samples are drawn by Box–Muller from
  float32 uniforms, z = r (cos θ, sin θ), r² = −2 ln U₁, θ = 2πU₂ (exactly N(0, I) up to float32
  resolution), which makes the weights free: 1/p ∝ exp(|z|²/2) = 1/U₁, and z ∈ S_min ⇔
  U₁ ≥ e⁻². The arithmetic is float32 (ample for an estimator whose error is ~1/√N). Pairs
  are processed in cache-sized chunks; ``rng`` is consumed pair by pair (2·N uniforms each),
  so a batch gives bit-for-bit the per-pair result of :func:`mc_pair`. If no draw falls in
  S_min (probability e^(−2N)) the estimate is undefined and returned as 0.
  With ``shared_samples=True`` one set of N draws serves every pair of the call (common random
  numbers): each pair's estimate is still eq. 55 with the same variance, but the errors of
  pairs scored in one call are correlated. Then |y|² is a quadratic form in the shared draw,
  [z₁², z₁z₂, z₂², z₁, z₂, 1]·c (6 coefficients per pair), so the whole batch is one float32
  matrix product (pairs × 6)·(6 × N) — the fast path for scoring many pairs at one instant
  (the fusion node). Do not use it for repeated trials of the same pair within one call.
- ``"glr"``: eq. 71, exp(−½ Δᵀ (R1 + R2)⁻¹ Δ).
- ``"glr_thresholded"``: the paper's §3 suggestion: GLR, but exactly 1 when one ellipse contains
  the other and exactly 0 when their overlap is empty (exact geometric tests from the
  intersection points of :mod:`.overlap`).
- ``"exact"``: the exact normalized overlap area (eq. 49), see :mod:`.overlap`.
"""

from __future__ import annotations

import numpy as np

from track_core.geofeasibility.overlap import containment, exact_overlap
from track_core.geofeasibility.validate import check_pairs

METHODS = ('mc', 'glr', 'glr_thresholded', 'exact')
_E2 = np.float32(np.exp(-2.0))
_CHUNK_ELEMS = 1 << 16   # pairs × samples per chunk (keeps the float32 work arrays in L2)


def _glr(mu1, R1, mu2, R2) -> np.ndarray:
    d = mu1 - mu2
    S = R1 + R2
    det = S[:, 0, 0] * S[:, 1, 1] - S[:, 0, 1] * S[:, 1, 0]
    q = (S[:, 1, 1] * d[:, 0] ** 2 - 2.0 * S[:, 0, 1] * d[:, 0] * d[:, 1] + S[:, 0, 0] * d[:, 1] ** 2) / det
    return np.exp(-0.5 * q)


def _mc_coefficients(mu1, R1, mu2, R2) -> np.ndarray:
    """Per pair, the map z ↦ y = A z + b with x = μ_min + L_min z and x ∈ S_other ⇔ |y|² ≤ 1.

    A = ½ L_o⁻¹ L_min is lower triangular; returns (n, 5) columns a11, a21, a22, b1, b2.
    """
    small1 = np.linalg.det(R1) <= np.linalg.det(R2)
    Rm = np.where(small1[:, None, None], R1, R2)
    Ro = np.where(small1[:, None, None], R2, R1)
    mm = np.where(small1[:, None], mu1, mu2)
    mo = np.where(small1[:, None], mu2, mu1)
    Lm = np.linalg.cholesky(Rm)
    Lo = np.linalg.cholesky(Ro)
    A = 0.5 * np.linalg.solve(Lo, Lm)
    b = 0.5 * np.linalg.solve(Lo, (mm - mo)[..., None])[..., 0]
    return np.stack([A[:, 0, 0], A[:, 1, 0], A[:, 1, 1], b[:, 0], b[:, 1]], axis=1)


def _mc_block(coef: np.ndarray, u: np.ndarray, stderr: bool):
    """Eq. 55 for a block: coef (m, 5) float32, u (m, 2, N) float32 uniforms in [0, 1)."""
    a11, a21, a22, b1, b2 = (coef[:, k:k + 1] for k in range(5))
    u1 = np.float32(1.0) - u[:, 0]                      # (0, 1]
    r = np.sqrt(np.float32(-2.0) * np.log(u1))
    th = u[:, 1] * np.float32(2.0 * np.pi)
    c, s = np.cos(th), np.sin(th)
    y1 = a11 * (r * c) + b1
    y2 = r * (a21 * c + a22 * s) + b2
    inside_other = (y1 * y1 + y2 * y2) <= np.float32(1.0)
    w = (u1 >= _E2) / u1                               # 1/p on S_min, 0 outside
    den = w.sum(axis=1, dtype=np.float64)
    wi = w * inside_other
    num = wi.sum(axis=1, dtype=np.float64)
    with np.errstate(invalid='ignore', divide='ignore'):
        g = np.where(den > 0, num / den, 0.0)
    if not stderr:
        return g, None
    # delta-method standard error of the ratio estimator
    resid = wi.astype(np.float64) - g[:, None] * w
    with np.errstate(invalid='ignore', divide='ignore'):
        se = np.where(den > 0, np.sqrt(np.sum(resid * resid, axis=1)) / den, 0.0)
    return g, se


def _mc_shared(coef: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Eq. 55 for every pair with one shared draw: coef (n, 5), u (2, N) uniforms in [0, 1)."""
    u1 = np.float32(1.0) - u[0]
    r = np.sqrt(np.float32(-2.0) * np.log(u1))
    th = u[1] * np.float32(2.0 * np.pi)
    z1, z2 = r * np.cos(th), r * np.sin(th)
    w = ((u1 >= _E2) / u1).astype(np.float32)          # 1/p on S_min, 0 outside
    keep = w > 0                                       # draws outside S_min never count
    z1, z2, w = z1[keep], z2[keep], w[keep]
    feats = np.stack([z1 * z1, z1 * z2, z2 * z2, z1, z2, np.ones_like(z1)])        # (6, N')
    a11, a21, a22, b1, b2 = coef.T
    quad = np.stack([a11 * a11 + a21 * a21, 2 * a21 * a22, a22 * a22, 2 * (a11 * b1 + a21 * b2),
                     2 * a22 * b2, b1 * b1 + b2 * b2], axis=1).astype(np.float32)   # (n, 6)
    den = float(w.sum(dtype=np.float64))
    if den <= 0:
        return np.zeros(len(coef))
    g = np.empty(len(coef))
    step = max(1, (_CHUNK_ELEMS * 16) // max(1, feats.shape[1]))
    for lo in range(0, len(coef), step):
        inside = (quad[lo:lo + step] @ feats) <= np.float32(1.0)
        g[lo:lo + step] = (inside @ w).astype(np.float64) / den
    return g


def mc_overlap(mu1, R1, mu2, R2, n_samples: int = 500, rng: np.random.Generator | None = None,
               *, return_stderr: bool = False, shared_samples: bool = False):
    """Eq. 55 on checked pairs (n, 2)/(n, 2, 2); returns g (n,) or (g, standard error)."""
    if int(n_samples) != n_samples or n_samples < 1:
        raise ValueError(f'n_samples must be an integer >= 1, got {n_samples!r}')
    n_samples = int(n_samples)
    rng = np.random.default_rng() if rng is None else rng
    coef = _mc_coefficients(mu1, R1, mu2, R2).astype(np.float32)
    if shared_samples:
        if return_stderr:
            raise ValueError('return_stderr is not available with shared_samples')
        return _mc_shared(coef, rng.random((2, n_samples), dtype=np.float32))
    n = coef.shape[0]
    g = np.empty(n)
    se = np.empty(n) if return_stderr else None
    step = max(1, _CHUNK_ELEMS // n_samples)
    for lo in range(0, n, step):
        hi = min(n, lo + step)
        u = rng.random((hi - lo, 2, n_samples), dtype=np.float32)
        gb, sb = _mc_block(coef[lo:hi], u, return_stderr)
        g[lo:hi] = gb
        if return_stderr:
            se[lo:hi] = sb
    return (g, se) if return_stderr else g


def score(mu1, R1, mu2, R2, method: str = 'exact', n_samples: int = 500,
          rng: np.random.Generator | None = None, *, shared_samples: bool = False) -> np.ndarray:
    """Geofeasibility score of each pair of 2σ ellipses, in [0, 1].

    mu1, mu2: (n, 2) or (2,); R1, R2: (n, 2, 2) or (2, 2) covariances (the 2σ ellipse is
    {x : (x − μ)ᵀ R⁻¹ (x − μ) ≤ 4}); single inputs broadcast. Returns (n,), or a 0-d array when
    every input is a single pair. ``method`` is one of ``"mc"``, ``"glr"``,
    ``"glr_thresholded"``, ``"exact"``; ``n_samples`` and ``rng`` are used by ``"mc"`` only
    (``rng=None`` draws a fresh unseeded generator: pass one for reproducible runs);
    ``shared_samples`` (``"mc"`` only) uses one draw for all pairs of the call (see above).
    Raises ``ValueError`` naming the pair index and reason for non-finite means or covariances
    that are not symmetric positive definite.
    """
    if method not in METHODS:
        raise ValueError(f'unknown method {method!r}; choose one of {", ".join(METHODS)}')
    m1, c1, m2, c2, single = check_pairs(mu1, R1, mu2, R2)
    if method == 'glr':
        g = _glr(m1, c1, m2, c2)
    elif method == 'glr_thresholded':
        g = _glr(m1, c1, m2, c2)
        contained, disjoint = containment(m1, c1, m2, c2)
        g = np.where(contained, 1.0, np.where(disjoint, 0.0, g))
    elif method == 'exact':
        g = exact_overlap(m1, c1, m2, c2)
    else:
        g = mc_overlap(m1, c1, m2, c2, n_samples, rng, shared_samples=shared_samples)
    return g.reshape(()) if single else g


def mc_pair(mu1, R1, mu2, R2, n_samples: int, rng: np.random.Generator) -> float:
    """Eq. 55 for one pair, written the way the paper ran it (one pair per call).

    The same maths and the same random stream as the batched ``"mc"``: used as the loop
    baseline of the benchmark and to test that batching changes nothing.
    """
    small1 = np.linalg.det(R1) <= np.linalg.det(R2)
    Rm, Ro, mm, mo = (R1, R2, mu1, mu2) if small1 else (R2, R1, mu2, mu1)
    Lm = np.linalg.cholesky(Rm)
    Lo = np.linalg.cholesky(Ro)
    A = (0.5 * np.linalg.solve(Lo, Lm)).astype(np.float32)
    b = (0.5 * np.linalg.solve(Lo, mm - mo)).astype(np.float32)
    u = rng.random((2, n_samples), dtype=np.float32)
    u1 = np.float32(1.0) - u[0]
    r = np.sqrt(np.float32(-2.0) * np.log(u1))
    th = u[1] * np.float32(2.0 * np.pi)
    c, s = np.cos(th), np.sin(th)
    y1 = A[0, 0] * (r * c) + b[0]
    y2 = r * (A[1, 0] * c + A[1, 1] * s) + b[1]
    inside = (y1 * y1 + y2 * y2) <= np.float32(1.0)
    w = (u1 >= _E2) / u1
    den = w.sum(dtype=np.float64)
    return float((w * inside).sum(dtype=np.float64) / den) if den > 0 else 0.0


def glr_pair(mu1, R1, mu2, R2) -> float:
    """Eq. 71 for one pair, the way the paper ran it (loop baseline of the benchmark)."""
    d = mu1 - mu2
    return float(np.exp(-0.5 * d @ np.linalg.solve(R1 + R2, d)))
