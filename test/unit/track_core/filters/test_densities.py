import numpy as np
import pytest
from scipy.stats import multivariate_normal

from track_core.filters import cholesky_jitter, gaussian_logpdf


def test_logpdf_matches_scipy_batched():
    rng = np.random.default_rng(0)
    A = rng.normal(size=(5, 3, 3))
    S = A @ np.swapaxes(A, -1, -2) + np.eye(3)
    d = rng.normal(size=(5, 3))
    ref = [multivariate_normal(np.zeros(3), S[i]).logpdf(d[i]) for i in range(5)]
    np.testing.assert_allclose(gaussian_logpdf(d, S), ref, rtol=1e-10)
    np.testing.assert_allclose(gaussian_logpdf(d[0], chol=np.linalg.cholesky(S[0])), ref[0], rtol=1e-10)


def test_cholesky_jitter_semidefinite():
    P = np.array([[[1.0, 1.0], [1.0, 1.0]], [[2.0, 0.0], [0.0, 1.0]]])
    L = cholesky_jitter(P)
    np.testing.assert_allclose(L @ np.swapaxes(L, -1, -2), P, atol=1e-6)
    assert L[1, 0, 0] == pytest.approx(np.sqrt(2.0))
