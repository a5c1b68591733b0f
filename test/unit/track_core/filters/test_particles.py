import numpy as np

from track_core.filters import weighted_mean_cov


def test_uniform_matches_numpy_biased_cov():
    x = np.random.default_rng(0).normal(size=(100, 3))
    m, P = weighted_mean_cov(x)
    np.testing.assert_allclose(m, x.mean(0))
    np.testing.assert_allclose(P, np.cov(x.T, bias=True), atol=1e-12)


def test_weights_select_particles():
    x = np.array([[0.0, 0.0], [2.0, 4.0], [10.0, 10.0]])
    m, P = weighted_mean_cov(x, np.array([1.0, 1.0, 0.0]))
    np.testing.assert_allclose(m, [1.0, 2.0])
    np.testing.assert_allclose(P, [[1.0, 2.0], [2.0, 4.0]])


def test_mixture_moments_are_within_plus_between():
    from track_core.filters import mixture_mean_cov

    m = np.array([[0.0, 0.0], [4.0, 0.0]])
    P = np.stack([np.eye(2), 3 * np.eye(2)])
    mean, cov = mixture_mean_cov(m, P, np.array([3.0, 1.0]))
    np.testing.assert_allclose(mean, [1.0, 0.0])
    # within: 0.75·I + 0.25·3I = 1.5 I; between: 0.75·1 + 0.25·9 = 3 on x
    np.testing.assert_allclose(cov, [[4.5, 0.0], [0.0, 1.5]])
    # a sampled check: draws from the mixture have these moments
    rng = np.random.default_rng(0)
    k = rng.random(200_000) < 0.25
    x = np.where(k[:, None], m[1] + np.sqrt(3) * rng.standard_normal((k.size, 2)), rng.standard_normal((k.size, 2)))
    np.testing.assert_allclose(np.cov(x.T), cov, atol=0.05)


def test_bimodality_coefficient_gaussian_uniform_two_modes():
    from track_core.filters import bimodality_coefficient

    rng = np.random.default_rng(1)
    g = rng.standard_normal((20_000, 4)) * [30.0, 1.0, 10.0, 1.0]
    assert abs(bimodality_coefficient(g) - 1 / 3) < 0.02
    u = np.column_stack([rng.uniform(-1, 1, 20_000), 0.01 * rng.standard_normal(20_000)])
    assert abs(bimodality_coefficient(u) - 5 / 9) < 0.02
    two = np.concatenate([g[:10_000] * 0.1 + [100, 0, 0, 0], g[10_000:] * 0.1 - [100, 0, 0, 0]])
    assert bimodality_coefficient(two) > 0.95
    # weights select one of the two modes: Gaussian again
    w = np.r_[np.ones(10_000), np.zeros(10_000)]
    assert abs(bimodality_coefficient(two, w) - 1 / 3) < 0.03
    assert np.isnan(bimodality_coefficient(np.ones((5, 2))))


def test_liu_west_move_keeps_the_clouds_mean_and_covariance_and_spreads_duplicates():
    from track_core.filters import liu_west_move, weighted_mean_cov

    rng = np.random.default_rng(4)
    base = rng.multivariate_normal([1.0, -2.0, 3.0], [[4.0, 1.0, 0.0], [1.0, 2.0, 0.5], [0.0, 0.5, 1.0]], size=500)
    x = base[rng.integers(0, 50, size=20_000)]  # a resampled cloud: 50 distinct values
    m0, c0 = weighted_mean_cov(x)
    moved = liu_west_move(x, np.random.default_rng(5))
    m1, c1 = weighted_mean_cov(moved)
    se = np.sqrt(np.diag(c0) / x.shape[0])
    assert np.all(np.abs(m1 - m0) < 4 * se)  # the mean, within its sampling error
    np.testing.assert_allclose(c1, c0, rtol=0.05, atol=0.05)  # the covariance, within 5 %
    assert np.unique(moved[:, 0]).size == x.shape[0]  # duplicates spread apart
