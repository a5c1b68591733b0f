"""Covariance intersection (CI) of two 2-D Gaussian estimates with unknown cross-correlation.

P⁻¹ = ω R1⁻¹ + (1 − ω) R2⁻¹,  μ = P (ω R1⁻¹ μ1 + (1 − ω) R2⁻¹ μ2),  ω ∈ [0, 1],
with ω minimising det P (Julier & Uhlmann). In 2-D, det(ω A + (1 − ω) B) with A = R1⁻¹,
B = R2⁻¹ is a quadratic in ω, so the optimal ω is exact and closed form: the best of the
endpoints and the vertex. Batched over leading dimensions; no iterative search.
"""

from __future__ import annotations

import numpy as np


def _det2(M: np.ndarray) -> np.ndarray:
    return M[..., 0, 0] * M[..., 1, 1] - M[..., 0, 1] * M[..., 1, 0]


def ci_weight(R1: np.ndarray, R2: np.ndarray) -> np.ndarray:
    """The ω ∈ [0, 1] that minimises det of the CI covariance, per pair."""
    A, B = np.linalg.inv(R1), np.linalg.inv(R2)
    D = A - B
    # det(B + ω D) = det B + ω·tr(adj(B) D) + ω²·det D
    c0 = _det2(B)
    c1 = B[..., 1, 1] * D[..., 0, 0] + B[..., 0, 0] * D[..., 1, 1] - B[..., 0, 1] * D[..., 1, 0] \
        - B[..., 1, 0] * D[..., 0, 1]
    c2 = _det2(D)
    with np.errstate(divide='ignore', invalid='ignore'):
        vertex = np.where(c2 < 0, -c1 / (2 * c2), 0.0)
    vertex = np.clip(np.nan_to_num(vertex), 0.0, 1.0)
    cands = np.stack([np.zeros_like(c0), np.ones_like(c0), vertex], axis=-1)
    vals = c0[..., None] + c1[..., None] * cands + c2[..., None] * cands**2
    return np.take_along_axis(cands, np.argmax(vals, axis=-1)[..., None], axis=-1)[..., 0]


def covariance_intersection(mu1: np.ndarray, R1: np.ndarray, mu2: np.ndarray, R2: np.ndarray
                            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Fused (μ, P, ω) of two estimates whose correlation is unknown; consistent for any correlation."""
    w = ci_weight(R1, R2)[..., None, None]
    A, B = np.linalg.inv(R1), np.linalg.inv(R2)
    info = w * A + (1 - w) * B
    P = np.linalg.inv(info)
    mu = np.einsum('...ij,...j->...i', P, np.einsum('...ij,...j->...i', w * A, mu1)
                   + np.einsum('...ij,...j->...i', (1 - w) * B, mu2))
    return mu, 0.5 * (P + np.swapaxes(P, -1, -2)), w[..., 0, 0]
