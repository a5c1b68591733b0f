"""References for checking the scores: the closed-form overlap of two circles, and the random pair
population of Fig. 6 (the experiments and the tests draw from it)."""

from __future__ import annotations

import numpy as np

from track_core.geofeasibility.ellipse import ellipse_to_gaussian


def circle_overlap(r1, r2, d) -> np.ndarray:
    """Closed-form normalized overlap (lens area / smaller disc area) of two circles, batched."""
    r1, r2, d = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (r1, r2, d)))
    with np.errstate(invalid='ignore', divide='ignore'):
        c1 = np.clip((d * d + r1 * r1 - r2 * r2) / (2 * d * r1), -1, 1)
        c2 = np.clip((d * d + r2 * r2 - r1 * r1) / (2 * d * r2), -1, 1)
        k = np.sqrt(np.maximum((-d + r1 + r2) * (d + r1 - r2) * (d - r1 + r2) * (d + r1 + r2), 0.0))
        lens = r1 * r1 * np.arccos(c1) + r2 * r2 * np.arccos(c2) - 0.5 * k
    g = lens / (np.pi * np.minimum(r1, r2) ** 2)
    g = np.where(d >= r1 + r2, 0.0, g)
    return np.where(d <= np.abs(r1 - r2), 1.0, g)


def random_pairs(n: int, rng: np.random.Generator):
    """The fig6 population: semi-axes U(0.5, 3), bearings U(0, π), centre distance U(0, r_max1 + r_max2)."""
    ax = rng.uniform(0.5, 3.0, (4, n))
    phi = rng.uniform(0.0, np.pi, (2, n))
    dist = rng.uniform(0.0, 1.0, n) * (np.maximum(ax[0], ax[1]) + np.maximum(ax[2], ax[3]))
    bearing = rng.uniform(0.0, 2 * np.pi, n)
    mu1, R1 = ellipse_to_gaussian(0.0, 0.0, ax[0], ax[1], phi[0])
    mu2, R2 = ellipse_to_gaussian(dist * np.sin(bearing), dist * np.cos(bearing), ax[2], ax[3], phi[1])
    return np.broadcast_to(mu1, (n, 2)), R1, mu2, R2
