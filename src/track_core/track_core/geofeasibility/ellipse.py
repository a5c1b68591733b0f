"""Ellipse ↔ Gaussian mapping of the paper's eqs. 56–59, batched.

The 2σ area of uncertainty of a report is the ellipse {x : (x − μ)ᵀ R⁻¹ (x − μ) ≤ 4} with

    U = [[sin φ,  cos φ],        (56)
         [cos φ, −sin φ]]
    Λ = diag(r_x²/4, r_y²/4)     (57)
    R = U Λ Uᵀ                   (58)
    μ = (x0, y0)                 (59)

Convention (read off eq. 56, in the ENU ``map`` frame, x east, y north):

- U's first column (sin φ, cos φ) is the direction of the r_x semi-axis, so **φ is the bearing
  of the r_x axis, measured clockwise from north (+y) towards east (+x)**, in radians — the
  navigation convention of the papers (``atan2(dx, dy)``). At φ = 0 the r_x axis points north,
  i.e. along y, not x. The r_y axis is at bearing φ + π/2.
- det U = −sin²φ − cos²φ = −1: eq. 56 is a *reflection*, not a rotation. R depends on each
  column only through its outer product, so flipping the sign of the second column gives the
  rotation U·diag(1, −1) with the same R; the reflection is harmless and we read eq. 56 as
  "the columns of U are the principal axes". Nothing downstream uses U's orientation.
- The inverse map is canonical: ``r_x ≥ r_y`` (r_x is the semi-major axis) and φ ∈ [0, π)
  (an axis has no direction). For a circle φ = 0. So ellipse → Gaussian → ellipse returns the
  input exactly when it is already canonical; Gaussian → ellipse → Gaussian always round-trips.
"""

from __future__ import annotations

import numpy as np


def ellipse_to_gaussian(x0, y0, rx, ry, phi) -> tuple[np.ndarray, np.ndarray]:
    """(x0, y0, r_x, r_y, φ) → (μ, R) by eqs. 56–59; arrays broadcast, μ (..., 2), R (..., 2, 2).

    ``rx``, ``ry`` are the 2σ semi-axes (> 0), ``phi`` the bearing of the r_x axis (rad,
    clockwise from north).
    """
    x0, y0, rx, ry, phi = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (x0, y0, rx, ry, phi)))
    if np.any(~np.isfinite(rx) | ~np.isfinite(ry) | (rx <= 0) | (ry <= 0)):
        raise ValueError('semi-axes r_x, r_y must be finite and > 0')
    if np.any(~np.isfinite(phi) | ~np.isfinite(x0) | ~np.isfinite(y0)):
        raise ValueError('centre and bearing must be finite')
    s, c = np.sin(phi), np.cos(phi)
    U = np.stack([np.stack([s, c], -1), np.stack([c, -s], -1)], -2)            # eq. 56
    lam = np.stack([rx**2 / 4.0, ry**2 / 4.0], -1)                               # eq. 57
    R = np.einsum('...ik,...k,...jk->...ij', U, lam, U)                          # eq. 58
    R = 0.5 * (R + np.swapaxes(R, -1, -2))
    mu = np.stack([x0, y0], -1)                                                  # eq. 59
    return mu, R


def gaussian_to_ellipse(mu, R) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(μ, R) → (x0, y0, r_x, r_y, φ), the inverse of eqs. 56–59 in canonical form.

    r_x ≥ r_y are the 2σ semi-axes (2·√eigenvalue), φ ∈ [0, π) the bearing of the r_x
    (major) axis, clockwise from north. R must be symmetric positive definite (not checked here;
    see :func:`track_core.geofeasibility.validate.check_pairs`).
    """
    mu = np.asarray(mu, dtype=float)
    R = np.asarray(R, dtype=float)
    a, b, c = R[..., 0, 0], 0.5 * (R[..., 0, 1] + R[..., 1, 0]), R[..., 1, 1]
    half_diff = 0.5 * (a - c)
    rad = np.hypot(half_diff, b)
    lam_max = 0.5 * (a + c) + rad
    lam_min = (a * c - b * b) / lam_max  # no cancellation for thin ellipses
    theta = 0.5 * np.arctan2(2.0 * b, a - c)  # major axis angle from +x, counter-clockwise
    phi = np.mod(0.5 * np.pi - theta, np.pi)
    phi = np.where(rad == 0.0, 0.0, phi)
    phi = np.where(phi >= np.pi, 0.0, phi)
    return mu[..., 0], mu[..., 1], 2.0 * np.sqrt(lam_max), 2.0 * np.sqrt(np.maximum(lam_min, 0.0)), phi
