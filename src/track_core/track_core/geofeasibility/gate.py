"""Gate for the exact score: the pairs whose 2σ ellipses can overlap, found without scoring them all.

Paper: Coates et al., *Recognized Maritime Picture: Geofeasibility Scores* (docs/PAPERS.md). Its
exact score (eq. 49, the normalized overlap area; closed form in :mod:`.overlap`) of two 2σ
ellipses S1, S2 is area(S1 ∩ S2) / min(area(S1), area(S2)): exactly 0 when the ellipses have no
common interior (externally tangent ones included: :mod:`.overlap` removes the double root of a
tangency and returns 0.0, tested). Most pairs of a real picture are far apart, so only the pairs
that can overlap are scored:

1. **Radius gate.** Each 2σ ellipse lies in the disc of its semi-major axis r = 2√λ_max
   around its centre (:func:`.ellipse.gaussian_to_ellipse`). A ``scipy.spatial.cKDTree`` on the
   centres returns the pairs within 2·max(r) (``query_pairs``), kept when
   |μ_i − μ_j| ≤ (r_i + r_j)(1 + ``margin``).
2. **Separating ellipse.** For any t > 0 the Minkowski sum S_i ⊕ (−S_j) lies in the ellipse
   {x : xᵀ S_t⁻¹ x ≤ 4}, S_t = (1 + 1/t) R_i + (1 + t) R_j, so the ellipses are disjoint when
   Δᵀ S_t⁻¹ Δ > 4 for Δ = μ_i − μ_j. With t = √(uᵀR_i u / uᵀR_j u), u = Δ/|Δ|, S_t is the
   tightest member along the centre line and the test is at least as strong as the projection of
   both ellipses onto that line (Cauchy–Schwarz). A pair is dropped when Δᵀ S_t⁻¹ Δ >
   4(1 + ``margin``)². Both tests are sufficient conditions for disjointness, never necessary
   ones, so a dropped pair is always disjoint; a kept pair may still score 0.

``margin`` (``GATE_RTOL`` = 1e-6, relative) keeps a dropped pair separated by a clear gap: tangent
or near-tangent pairs (gap below 1e-6 of the radii) are scored by the exact routine, which
already returns 0 for them (its tangency handling, :mod:`.overlap` step 4), so the gated result
is identical to scoring every pair (tests compare them exactly, tangent and nested layouts
included). Everything is vectorised over tracks and pairs; the result is sorted (i < j,
lexicographic) like ``numpy.triu_indices``.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from track_core.geofeasibility.ellipse import gaussian_to_ellipse
from track_core.geofeasibility.scores import score

GATE_RTOL = 1e-6
GATED_METHODS = ('exact',)   # methods whose score is exactly 0 for disjoint ellipses and is a pure function of a pair


def semi_major(R: np.ndarray) -> np.ndarray:
    """2σ semi-major axis 2√λ_max of each covariance (n, 2, 2) → (n,)."""
    R = np.asarray(R, dtype=float).reshape(-1, 2, 2)
    return gaussian_to_ellipse(np.zeros((len(R), 2)), R)[2]


def separated(mu_i, R_i, mu_j, R_j, margin: float = GATE_RTOL) -> np.ndarray:
    """True where the 2σ ellipses of the pairs are certainly disjoint (step 2 above), batched."""
    d = np.asarray(mu_i, float) - np.asarray(mu_j, float)
    R_i, R_j = np.asarray(R_i, float), np.asarray(R_j, float)
    dist2 = np.einsum('ni,ni->n', d, d)
    with np.errstate(divide='ignore', invalid='ignore'):
        a = np.einsum('ni,nij,nj->n', d, R_i, d) / dist2
        b = np.einsum('ni,nij,nj->n', d, R_j, d) / dist2
        t = np.sqrt(a / b)
        S = (1.0 + 1.0 / t)[:, None, None] * R_i + (1.0 + t)[:, None, None] * R_j
        det = S[:, 0, 0] * S[:, 1, 1] - S[:, 0, 1] * S[:, 1, 0]
        q = (S[:, 1, 1] * d[:, 0] ** 2 - 2.0 * S[:, 0, 1] * d[:, 0] * d[:, 1] + S[:, 0, 0] * d[:, 1] ** 2) / det
        out = q > 4.0 * (1.0 + margin) ** 2
    return out & np.isfinite(q) & (dist2 > 0)


def candidate_pairs(mu, R, margin: float = GATE_RTOL) -> tuple[np.ndarray, np.ndarray]:
    """Rows (i, j), i < j, of the pairs of tracks μ (n, 2), R (n, 2, 2) whose 2σ ellipses may overlap.

    Every pair not returned has disjoint ellipses (exact score 0). Inputs must be finite with
    positive definite covariances (checked by the caller, e.g. ``validate.check_pairs``).
    """
    mu = np.asarray(mu, dtype=float).reshape(-1, 2)
    if len(mu) < 2:
        return np.zeros(0, np.intp), np.zeros(0, np.intp)
    r = semi_major(R)
    reach = 2.0 * float(np.max(r)) * (1.0 + margin)
    ij = cKDTree(mu).query_pairs(reach, output_type='ndarray')
    if ij.size == 0:
        return np.zeros(0, np.intp), np.zeros(0, np.intp)
    i, j = ij[:, 0].astype(np.intp), ij[:, 1].astype(np.intp)
    d = mu[i] - mu[j]
    keep = np.einsum('ni,ni->n', d, d) <= ((r[i] + r[j]) * (1.0 + margin)) ** 2
    i, j = i[keep], j[keep]
    R = np.asarray(R, dtype=float).reshape(-1, 2, 2)
    keep = ~separated(mu[i], R[i], mu[j], R[j], margin)
    i, j = i[keep], j[keep]
    order = np.lexsort((j, i))
    return i[order], j[order]


def gated_score(mu, R, i, j, method: str = 'exact', **kw) -> tuple[np.ndarray, np.ndarray]:
    """Scores of the pairs (i[k], j[k]) of tracks μ, R, scoring only the candidates; (scores, candidate mask).

    Equal to ``score(mu[i], R[i], mu[j], R[j], method)`` for ``method`` in ``GATED_METHODS``: the
    pairs outside :func:`candidate_pairs` are disjoint and score exactly 0. ``i``, ``j`` must hold
    each pair once with i < j (as ``numpy.triu_indices``); ``kw`` goes to :func:`.scores.score`.
    """
    if method not in GATED_METHODS:
        raise ValueError(f'method {method!r} cannot be gated; gated methods: {", ".join(GATED_METHODS)}')
    mu = np.asarray(mu, dtype=float).reshape(-1, 2)
    R = np.asarray(R, dtype=float).reshape(-1, 2, 2)
    i, j = np.asarray(i, np.intp), np.asarray(j, np.intp)
    s = np.zeros(i.size)
    ci, cj = candidate_pairs(mu, R)
    n = max(len(mu), 1)
    ckeys = ci.astype(np.int64) * n + cj                      # sorted: candidate_pairs orders (i, j)
    keys = i.astype(np.int64) * n + j
    pos = np.minimum(np.searchsorted(ckeys, keys), max(ckeys.size - 1, 0))
    cand = (ckeys[pos] == keys) if ckeys.size else np.zeros(i.size, bool)
    if cand.any():
        s[cand] = np.atleast_1d(score(mu[i[cand]], R[i[cand]], mu[j[cand]], R[j[cand]], method, **kw))
    return s, cand
