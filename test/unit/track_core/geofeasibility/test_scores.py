"""MC (eq. 55), GLR (eq. 71) and thresholded GLR."""

import numpy as np
import pytest
from scipy.stats import norm

from track_core.geofeasibility import ellipse_to_gaussian, score
from track_core.geofeasibility.reference import random_pairs
from track_core.geofeasibility.scores import glr_pair, mc_overlap, mc_pair
from track_core.geofeasibility.validate import check_pairs


def _band(g, n_samples, n_pairs, alpha=1e-3):
    """Two-sided (1 − α) family-wise band of eq. 55 around the true value g.

    Weights 1/p on S_min lie in [w0, e² w0] with area(S_min) = 2 w0, so the ratio estimator's
    variance is at most e² g (1 − g) / (2N); Bonferroni over the pairs; plus 1/N for the O(1/N)
    bias of a ratio estimator.
    """
    z = norm.ppf(1 - alpha / (2 * n_pairs))
    return z * np.sqrt(np.e**2 * g * (1 - g) / (2 * n_samples)) + 1.0 / n_samples


@pytest.mark.parametrize('n_samples', [500, 5000])
def test_exact_lies_in_the_mc_confidence_band(n_samples):
    rng = np.random.default_rng(10)
    n = 400
    pairs = random_pairs(n, rng)
    exact = score(*pairs, 'exact')
    mc = score(*pairs, 'mc', n_samples=n_samples, rng=rng)
    assert np.all(np.abs(mc - exact) <= _band(exact, n_samples, n))
    # and the band is not vacuous: the errors have the 1/√N scale
    assert np.sqrt(np.mean((mc - exact) ** 2)) < 0.6 * np.sqrt(np.e**2 / 8 / n_samples)


def test_mc_stderr_estimate_matches_the_spread():
    rng = np.random.default_rng(11)
    mu1, R1 = ellipse_to_gaussian(0, 0, 2.0, 1.0, 0.3)
    mu2, R2 = ellipse_to_gaussian(1.0, 0.5, 1.5, 1.2, 1.0)
    trials = 2000
    pairs = check_pairs(np.tile(mu1, (trials, 1)), R1, mu2, R2)[:4]
    g, se = mc_overlap(*pairs, n_samples=500, rng=rng, return_stderr=True)
    # spread of 2000 estimates vs the mean reported standard error, within 3 sampling sds (≈ 3·1.6 %)
    assert np.std(g) == pytest.approx(np.mean(se), rel=0.05)
    assert np.mean(g) == pytest.approx(float(score(mu1, R1, mu2, R2, 'exact')), abs=4 * np.std(g) / np.sqrt(trials))


def test_mc_is_reproducible_and_batched_equals_the_per_pair_loop():
    pairs = random_pairs(300, np.random.default_rng(12))
    a = score(*pairs, 'mc', rng=np.random.default_rng(7))
    b = score(*pairs, 'mc', rng=np.random.default_rng(7))
    assert np.array_equal(a, b)
    rng = np.random.default_rng(7)
    loop = np.array([mc_pair(*(np.asarray(p[i]) for p in pairs), 500, rng) for i in range(300)])
    assert np.array_equal(a, loop)
    # independent samples per pair: identical pairs get different estimates
    same = score(np.zeros((50, 2)), np.eye(2), np.ones((50, 2)), np.eye(2), 'mc', rng=np.random.default_rng(1))
    assert np.unique(same).size > 30


def test_mc_rejects_bad_sample_counts():
    with pytest.raises(ValueError, match='n_samples'):
        score(np.zeros(2), np.eye(2), np.ones(2), np.eye(2), 'mc', n_samples=0)
    with pytest.raises(ValueError, match='n_samples'):
        score(np.zeros(2), np.eye(2), np.ones(2), np.eye(2), 'mc', n_samples=2.5)


def test_glr_is_eq71_and_matches_the_per_pair_formula():
    mu1, R1, mu2, R2 = random_pairs(200, np.random.default_rng(13))
    g = score(mu1, R1, mu2, R2, 'glr')
    for i in range(200):
        d = mu1[i] - mu2[i]
        assert g[i] == pytest.approx(np.exp(-0.5 * d @ np.linalg.inv(R1[i] + R2[i]) @ d), rel=1e-12)
        assert g[i] == pytest.approx(glr_pair(mu1[i], R1[i], mu2[i], R2[i]), rel=1e-12)
    # never exactly 0 or 1 (the paper's remark), unless the centres coincide
    assert np.all((g > 0) & (g < 1))


def test_glr_thresholded_forces_only_the_geometric_extremes():
    pairs = random_pairs(3000, np.random.default_rng(14))
    glr = score(*pairs, 'glr')
    thr = score(*pairs, 'glr_thresholded')
    exact = score(*pairs, 'exact')
    assert np.all(thr[exact == 1.0] == 1.0) and np.all(thr[exact == 0.0] == 0.0)
    partial = (exact > 0) & (exact < 1)
    assert np.array_equal(thr[partial], glr[partial])
    assert np.any(exact == 0) and np.any(exact == 1)


def test_mc_shared_samples_equal_the_per_pair_estimate_on_the_same_draw():
    """With one shared draw, pair k's estimate equals mc_pair run on that very draw."""
    from track_core.geofeasibility.reference import random_pairs
    from track_core.geofeasibility.scores import mc_pair

    mu1, R1, mu2, R2 = random_pairs(50, np.random.default_rng(8))
    shared = score(mu1, R1, mu2, R2, 'mc', 400, np.random.default_rng(9), shared_samples=True)
    for k in range(50):
        own = mc_pair(mu1[k], R1[k], mu2[k], R2[k], 400, np.random.default_rng(9))
        # float32 expansion of |y|² may flip a sample sitting on the boundary: allow one weight
        assert abs(shared[k] - own) < 0.05, k


def test_mc_shared_samples_are_unbiased_against_exact():
    from track_core.geofeasibility.reference import random_pairs

    mu1, R1, mu2, R2 = random_pairs(200, np.random.default_rng(10))
    exact = score(mu1, R1, mu2, R2, 'exact')
    rng = np.random.default_rng(11)
    est = np.mean([score(mu1, R1, mu2, R2, 'mc', 500, rng, shared_samples=True) for _ in range(40)], axis=0)
    # 40 independent calls x 500 draws: standard error <= 0.5/sqrt(500*40*0.86) ~ 0.004 per pair
    assert np.max(np.abs(est - exact)) < 6 * 0.5 / np.sqrt(500 * 40 * 0.86)
