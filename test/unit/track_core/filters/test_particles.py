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
