"""The gate of the exact score: gated scoring equals scoring every pair, bit for bit."""

import numpy as np
import pytest

from track_core.geofeasibility import ellipse_to_gaussian, score
from track_core.geofeasibility.gate import candidate_pairs, gated_score, semi_major, separated


def _all_pairs(mu, R):
    i, j = np.triu_indices(len(mu), 1)
    return i, j, score(mu[i], R[i], mu[j], R[j], 'exact')


def _random_layout(rng, n, spread):
    """n rotated ellipses, 2σ semi-axes 1–30 (aspect up to 10), centres uniform in a square of side ``spread``."""
    rx = rng.uniform(1.0, 30.0, n)
    ry = rx / rng.uniform(1.0, 10.0, n)
    mu, R = ellipse_to_gaussian(*rng.uniform(0.0, spread, (2, n)), rx, ry, rng.uniform(0, np.pi, n))
    return mu, R


def _touching_layout():
    """Tangent (outside and inside), nested, identical, crossing and near-tangent pairs of ellipses."""
    circ = []  # (x, y, rx, ry, phi)
    for k, gap in enumerate([0.0, 1e-15, -1e-15, 1e-12, -1e-12, 1e-9, -1e-9, 1e-6, -1e-6, 1e-3, -1e-3]):
        y = 200.0 * k
        circ += [(0.0, y, 5.0, 5.0, 0.0), (5.0 + 3.0 + gap, y, 3.0, 3.0, 0.0)]              # circles, outside
        circ += [(100.0, y, 5.0, 5.0, 0.0), (100.0 + 5.0 - 2.0 + gap, y, 2.0, 2.0, 0.0)]    # circles, inside
        # axis-aligned ellipses tangent at the ends of their axes (φ = π/2: r_x along east)
        circ += [(50.0, y, 8.0, 2.0, np.pi / 2), (50.0 + 8.0 + 4.0 * (1 + gap), y, 4.0, 1.0, np.pi / 2)]
        circ += [(150.0, y, 8.0, 2.0, np.pi / 2), (150.0, y + 2.0 + 3.0 + gap, 6.0, 3.0, np.pi / 2)]
    circ += [(400.0, 0.0, 6.0, 2.0, 0.3), (400.0, 0.0, 6.0, 2.0, 0.3)]        # identical
    circ += [(450.0, 0.0, 10.0, 9.0, 0.0), (450.5, 0.2, 3.0, 1.0, 1.0)]        # nested
    circ += [(500.0, 0.0, 10.0, 1.0, 0.0), (500.0, 0.0, 10.0, 1.0, np.pi / 2)]  # crossing
    circ += [(550.0, 0.0, 20.0, 0.5, np.pi / 2), (550.0, 1.2, 20.0, 0.5, np.pi / 2)]  # parallel, apart
    x, y, rx, ry, phi = np.array(circ).T
    return ellipse_to_gaussian(x, y, rx, ry, phi)


@pytest.mark.parametrize('seed', [0, 1, 2, 3])
@pytest.mark.parametrize('spread', [50.0, 300.0, 3000.0])
def test_gated_scores_equal_scoring_every_pair_on_random_layouts(seed, spread):
    mu, R = _random_layout(np.random.default_rng(seed), 150, spread)
    i, j, full = _all_pairs(mu, R)
    gated, cand = gated_score(mu, R, i, j)
    np.testing.assert_array_equal(gated, full)
    assert np.all(full[~cand] == 0.0)
    if spread >= 300.0:
        assert cand.sum() < 0.5 * i.size  # the gate prunes a spread picture


def test_gated_scores_equal_every_pair_for_tangent_nested_and_identical_ellipses():
    mu, R = _touching_layout()
    i, j, full = _all_pairs(mu, R)
    gated, cand = gated_score(mu, R, i, j)
    np.testing.assert_array_equal(gated, full)
    assert full.max() == 1.0 and np.any(full[cand] == 0.0)  # nested/identical score 1; tangent pairs kept, 0


def test_gated_scores_in_clusters_of_coincident_centres():
    """Stacked reports of one moored ship: many centres equal or within a metre."""
    rng = np.random.default_rng(7)
    mu, R = _random_layout(rng, 120, 2000.0)
    mu[:40] = mu[0] + rng.normal(0.0, 0.5, (40, 2)) * (rng.random((40, 1)) < 0.5)
    i, j, full = _all_pairs(mu, R)
    np.testing.assert_array_equal(gated_score(mu, R, i, j)[0], full)


def test_candidates_are_sorted_unique_and_a_superset_of_the_overlapping_pairs():
    mu, R = _random_layout(np.random.default_rng(5), 200, 400.0)
    ci, cj = candidate_pairs(mu, R)
    assert np.all(ci < cj)
    keys = ci * 200 + cj
    assert np.all(np.diff(keys) > 0)
    i, j, full = _all_pairs(mu, R)
    assert set((i * 200 + j)[full > 0]) <= set(keys.tolist())


def test_separating_ellipse_drops_disjoint_pairs_the_radius_gate_keeps():
    # two long parallel ellipses 1.2 apart across their length: the discs of radius 20 overlap
    mu, R = ellipse_to_gaussian([0.0, 0.0], [0.0, 1.2], [20.0, 20.0], [0.5, 0.5], [np.pi / 2, np.pi / 2])
    assert np.hypot(*(mu[0] - mu[1])) < semi_major(R).sum()
    assert separated(mu[:1], R[:1], mu[1:], R[1:]).tolist() == [True]
    assert float(score(mu[0], R[0], mu[1], R[1])) == 0.0
    assert candidate_pairs(mu, R)[0].size == 0
    # overlapping and tangent pairs are never declared separated
    mu2, R2 = ellipse_to_gaussian([0.0, 0.0], [0.0, 1.0], [20.0, 20.0], [0.5, 0.5], [np.pi / 2, np.pi / 2])
    assert separated(mu2[:1], R2[:1], mu2[1:], R2[1:]).tolist() == [False]
    assert candidate_pairs(mu2, R2)[0].tolist() == [0]


def test_semi_major_is_the_2_sigma_major_axis():
    _, R = ellipse_to_gaussian([0.0], [0.0], [7.0], [2.0], [0.4])
    np.testing.assert_allclose(semi_major(R), [7.0])


def test_only_the_exact_method_is_gated():
    mu, R = _random_layout(np.random.default_rng(0), 5, 10.0)
    with pytest.raises(ValueError, match='cannot be gated'):
        gated_score(mu, R, np.array([0]), np.array([1]), 'glr')


@pytest.mark.parametrize('gap', [0.0, 1e-15, -1e-15, 1e-12, 1e-9])
def test_the_exact_score_of_externally_tangent_or_barely_apart_ellipses_is_exactly_zero(gap):
    """What the gate relies on at its margin: tangency (a double root) gives 0.0, not a rounding residue."""
    mu, R = ellipse_to_gaussian([0.0, 8.0 + gap, 50.0, 62.0 + 4.0 * gap], [0.0, 0.0, 0.0, 0.0],
                                [5.0, 3.0, 8.0, 4.0], [5.0, 3.0, 2.0, 1.0], [0.0, 0.0, np.pi / 2, np.pi / 2])
    assert score(mu[[0, 2]], R[[0, 2]], mu[[1, 3]], R[[1, 3]]).tolist() == [0.0, 0.0]
