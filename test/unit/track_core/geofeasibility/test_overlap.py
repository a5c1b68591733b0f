"""Exact overlap (eq. 49): closed-form circles, an independent quadrature, degenerate cases."""

import numpy as np
import pytest

from track_core.geofeasibility import containment, ellipse_to_gaussian, score
from track_core.geofeasibility.reference import circle_overlap, random_pairs


def _circles(r1, r2, d, theta):
    n = len(d)
    R1 = (np.asarray(r1) ** 2 / 4)[:, None, None] * np.eye(2)
    R2 = (np.asarray(r2) ** 2 / 4)[:, None, None] * np.eye(2)
    mu2 = np.stack([d * np.cos(theta), d * np.sin(theta)], 1) + 10.0
    return np.full((n, 2), 10.0), R1, mu2, R2


def test_circles_match_the_closed_form_lens_to_1e9():
    rng = np.random.default_rng(0)
    n = 5000
    r1, r2 = rng.uniform(0.05, 5.0, (2, n))
    d = rng.uniform(0.0, 1.2, n) * (r1 + r2)
    g = score(*_circles(r1, r2, d, rng.uniform(0, 2 * np.pi, n)), 'exact')
    ref = circle_overlap(r1, r2, d)
    assert np.max(np.abs(g - ref)) < 1e-9
    assert np.any(ref == 0) and np.any(ref == 1) and np.mean((ref > 0) & (ref < 1)) > 0.5


def test_matches_independent_quadrature_on_random_pairs(reference_overlap):
    rng = np.random.default_rng(1)
    mu1, R1, mu2, R2 = random_pairs(40, rng)
    g = score(mu1, R1, mu2, R2, 'exact')
    ref = np.array([reference_overlap(mu1[i], R1[i], mu2[i], R2[i]) for i in range(40)])
    assert np.sum((ref > 0) & (ref < 1)) >= 20
    assert np.max(np.abs(g - ref)) < 1e-9


@pytest.mark.parametrize('offset', [0.0, 0.3, 0.99, 1.0, 1.01, 2.5, 2.999])
def test_aspect_ratio_1e4_against_quadrature(reference_overlap, offset):
    # a 2σ ellipse 10⁴ × 1 (axis-aligned, so the float matrix is exact) and a circle of radius 2
    thin = np.diag([1e8 / 4, 1.0 / 4])
    circ = np.eye(2)
    g = float(score(np.zeros(2), thin, np.array([0.0, offset]), circ, 'exact'))
    assert g == pytest.approx(reference_overlap(np.zeros(2), thin, np.array([0.0, offset]), circ), abs=1e-9)
    # and the thin one the smaller: 1 × 10⁻⁴
    thin2 = np.diag([1.0 / 4, 1e-8 / 4])
    g2 = float(score(np.array([offset - 1.5, 0.2]), thin2, np.zeros(2), circ, 'exact'))
    ref2 = reference_overlap(np.array([offset - 1.5, 0.2]), thin2, np.zeros(2), circ)
    assert g2 == pytest.approx(ref2, abs=1e-9)


def test_rotated_aspect_1e4_is_rotation_invariant_to_the_float_representation_limit():
    """A rotated 10⁴:1 matrix defines its minor axis only to ~eps·κ² ≈ 2e-8 relative."""
    base = score(*ellipse_to_gaussian(0, 0, 1e4, 1.0, 0.0), *ellipse_to_gaussian(0.7, 0.2, 3.0, 3.0, 0.0), 'exact')
    for phi in (0.1, 0.7, 1.3, 2.9):
        s, c = np.sin(phi), np.cos(phi)
        # rotate the whole configuration by the same bearing change: centre (0.7, 0.2) moves too
        rot = np.array([[c, s], [-s, c]])
        mu2 = rot @ np.array([0.7, 0.2])
        g = score(*ellipse_to_gaussian(0, 0, 1e4, 1.0, phi), *ellipse_to_gaussian(*mu2, 3.0, 3.0, 0.0), 'exact')
        assert float(g) == pytest.approx(float(base), abs=2e-8)


def test_containment_is_1_and_disjoint_is_0_exactly():
    rng = np.random.default_rng(2)
    n = 500
    big = ellipse_to_gaussian(0, 0, rng.uniform(5, 8, n), rng.uniform(5, 8, n), rng.uniform(0, np.pi, n))
    small_in = ellipse_to_gaussian(*rng.uniform(-1, 1, (2, n)), rng.uniform(0.1, 2, n), rng.uniform(0.1, 2, n),
                                   rng.uniform(0, np.pi, n))
    small_out = ellipse_to_gaussian(*(rng.choice([-1, 1], (2, n)) * 20.0), rng.uniform(0.1, 2, n),
                                    rng.uniform(0.1, 2, n), rng.uniform(0, np.pi, n))
    mu_big = np.broadcast_to(big[0], (n, 2))
    for method in ('exact', 'glr_thresholded'):
        assert np.all(score(mu_big, big[1], *small_in, method) == 1.0)
        assert np.all(score(*small_in, mu_big, big[1], method) == 1.0)
        assert np.all(score(mu_big, big[1], *small_out, method) == 0.0)
    assert np.all(score(mu_big, big[1], *small_in, 'mc', rng=rng) == 1.0)
    assert np.all(score(mu_big, big[1], *small_out, 'mc', rng=rng) == 0.0)
    inside, apart = containment(mu_big, big[1], *small_in)
    assert inside.all() and not apart.any()


def test_tangency():
    R = np.eye(2) / 4                                   # circle of 2σ radius 1
    z = np.zeros(2)
    assert score(z, R, np.array([2.0, 0.0]), R, 'exact') == 0.0              # external
    assert score(z, R, np.array([0.0, 2.0]), R, 'glr_thresholded') == 0.0
    assert score(z, R, np.array([1.0, 0.0]), 4 * R, 'exact') == 1.0          # internal
    # ellipse 2 × 1 inscribed in the circle of radius 2, touching at (±2, 0)
    assert score(z, np.diag([1.0, 0.25]), z, np.eye(2), 'exact') == 1.0
    # osculating circle at the vertex (2, 0) of that ellipse (radius of curvature b²/a = 0.5)
    assert score(z, np.diag([1.0, 0.25]), np.array([1.5, 0.0]), np.eye(2) * 0.25 ** 2, 'exact') == 1.0
    # tangent rotated ellipses along a shared tangent line, and nearly tangent ones
    mu1, R1 = ellipse_to_gaussian(0, 0, 3, 1, 0.3)
    n = np.array([np.cos(0.3), -np.sin(0.3)])          # direction of the r_y axis
    for gap, expect in ((0.0, 0.0), (1e-9, 0.0)):
        mu2, R2 = ellipse_to_gaussian(*(2.0 * n + gap * n), 3, 1, 0.3)
        assert float(score(mu1, R1, mu2, R2, 'exact')) == pytest.approx(expect, abs=1e-12)


def test_nearly_tangent_crossing_is_continuous(reference_overlap):
    z = np.zeros(2)
    for eps in (1e-3, 1e-5, 1e-7):
        mu2 = np.array([2.0 - eps, 0.0])
        g = float(score(z, np.eye(2) / 4, mu2, np.diag([0.25, 1.0]), 'exact'))
        assert g == pytest.approx(reference_overlap(z, np.eye(2) / 4, mu2, np.diag([0.25, 1.0])), abs=1e-9)
        assert 0.0 <= g < 1e-3


def test_identical_and_near_identical():
    rng = np.random.default_rng(3)
    n = 200
    mu, R = ellipse_to_gaussian(*rng.normal(size=(2, n)), rng.uniform(0.5, 5, n), rng.uniform(0.5, 5, n),
                                rng.uniform(0, np.pi, n))
    assert np.all(score(mu, R, mu, R, 'exact') == 1.0)
    for eps in (1e-12, 1e-10):
        dmu = eps * rng.normal(size=(n, 2))
        dR = eps * rng.normal(size=(n, 2, 2))
        g = score(mu, R, mu + dmu, R * (1 + dR + np.swapaxes(dR, 1, 2)), 'exact')
        assert np.all(np.isfinite(g))
        assert np.max(1.0 - g) < 100 * eps


def test_no_nan_on_a_zoo_of_degenerate_configurations():
    cases = []
    z = np.zeros(2)
    for R2 in (np.eye(2) / 4, np.diag([1e8, 1.0]) / 4, np.diag([1.0, 1e-8]) / 4):
        for mu2 in (z, np.array([1.0, 0.0]), np.array([2.0, 0.0]), np.array([0.0, 1.0]), np.array([1e-9, 0.0]),
                    np.array([0.5, 0.5]), np.array([1e4, 0.0])):
            cases.append((z, np.eye(2) / 4, mu2, R2))
    mu1, R1, mu2, R2 = (np.array(v) for v in zip(*cases, strict=True))
    g = score(mu1, R1, mu2, R2, 'exact')
    assert np.all(np.isfinite(g)) and np.all((g >= 0) & (g <= 1))
    # batched equals one pair at a time, for every deterministic method
    for method in ('exact', 'glr', 'glr_thresholded'):
        b = score(mu1, R1, mu2, R2, method)
        one = np.array([float(score(mu1[i], R1[i], mu2[i], R2[i], method)) for i in range(len(cases))])
        assert np.array_equal(b, one)


def test_batched_equals_per_pair_on_random_pairs():
    rng = np.random.default_rng(4)
    pairs = random_pairs(300, rng)
    for method in ('exact', 'glr', 'glr_thresholded'):
        b = score(*pairs, method)
        one = np.array([float(score(*(p[i] for p in pairs), method)) for i in range(300)])
        assert np.array_equal(b, one)


def test_symmetric_in_the_two_ellipses():
    rng = np.random.default_rng(5)
    mu1, R1, mu2, R2 = random_pairs(2000, rng)
    assert np.max(np.abs(score(mu1, R1, mu2, R2, 'exact') - score(mu2, R2, mu1, R1, 'exact'))) < 1e-12
