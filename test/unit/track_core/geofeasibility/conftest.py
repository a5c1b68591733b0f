"""Fixtures: an independent reference for the exact overlap: slice-by-slice quadrature (no quartic, no arcs).

area(E1 ∩ E2) = ∫ max(0, min(hi1, hi2) − max(lo1, lo2)) dx, where [lo_i(x), hi_i(x)] is the
vertical chord of ellipse i at x (from the quadratic form directly). The integrand is smooth
except at the x-extremes of the ellipses (square-root ends, handled by QUADPACK's extrapolation)
and where two chord ends cross (kinks), which are located here by sign changes on a dense grid
and bisection, then used as breakpoints.
"""

from __future__ import annotations

import itertools
import warnings

import numpy as np
import pytest
from scipy.integrate import IntegrationWarning, quad
from scipy.optimize import brentq


def _chord(mu, R):
    Q = np.linalg.inv(4.0 * np.asarray(R, float))
    half = np.sqrt(4.0 * R[0, 0])

    def ends(x):
        dx = x - mu[0]
        a, b, c = Q[1, 1], 2.0 * Q[0, 1] * dx, Q[0, 0] * dx * dx - 1.0
        disc = max(b * b - 4.0 * a * c, 0.0)
        sq = np.sqrt(disc)
        return mu[1] + (-b - sq) / (2.0 * a), mu[1] + (-b + sq) / (2.0 * a)

    return mu[0] - half, mu[0] + half, ends


def slice_overlap(mu1, R1, mu2, R2) -> float:
    """Normalized overlap area by adaptive quadrature, accurate to ~1e-12 for moderate shapes."""
    a1, b1, e1 = _chord(np.asarray(mu1, float), np.asarray(R1, float))
    a2, b2, e2 = _chord(np.asarray(mu2, float), np.asarray(R2, float))
    lo, hi = max(a1, a2), min(b1, b2)
    small = np.pi * 4.0 * np.sqrt(min(np.linalg.det(R1), np.linalg.det(R2)))
    if lo >= hi:
        return 0.0

    def h(x):
        l1, u1 = e1(x)
        l2, u2 = e2(x)
        return max(0.0, min(u1, u2) - max(l1, l2))

    def diffs(x):
        l1, u1 = e1(x)
        l2, u2 = e2(x)
        return np.array([u1 - u2, l1 - l2, u1 - l2, u2 - l1])

    grid = np.linspace(lo, hi, 4001)
    vals = np.array([diffs(x) for x in grid])
    brk = {lo, hi}
    for k in range(4):
        sgn = np.sign(vals[:, k])
        for j in np.flatnonzero(sgn[:-1] * sgn[1:] < 0):
            brk.add(brentq(lambda x, k=k: diffs(x)[k], grid[j], grid[j + 1], xtol=1e-15, rtol=1e-15))
    pts = sorted(brk)
    total = 0.0
    with warnings.catch_warnings():
        warnings.simplefilter('ignore', IntegrationWarning)
        for x0, x1 in itertools.pairwise(pts):
            if x1 > x0:
                total += quad(h, x0, x1, epsabs=1e-15, epsrel=1e-13, limit=500)[0]
    return total / small


@pytest.fixture
def reference_overlap():
    """The independent slice-quadrature reference :func:`slice_overlap`."""
    return slice_overlap
