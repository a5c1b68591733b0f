import numpy as np
import pytest

from track_core.filters.covariance_intersection import ci_weight, covariance_intersection


def _random_spd(rng, n):
    A = rng.normal(size=(n, 2, 2))
    return A @ np.swapaxes(A, -1, -2) + 0.1 * np.eye(2)


def test_closed_form_weight_matches_dense_grid_search():
    rng = np.random.default_rng(1)
    R1, R2 = _random_spd(rng, 200), _random_spd(rng, 200)
    w = ci_weight(R1, R2)
    grid = np.linspace(0, 1, 20001)
    A, B = np.linalg.inv(R1), np.linalg.inv(R2)
    dets = np.linalg.det(grid[:, None, None, None] * A + (1 - grid[:, None, None, None]) * B)  # (g, n)
    w_grid = grid[np.argmax(dets, axis=0)]
    best = dets.max(axis=0)
    ours = np.linalg.det(w[:, None, None] * A + (1 - w[:, None, None]) * B)
    assert np.all(ours >= best * (1 - 1e-9))  # never worse than the grid
    assert np.abs(w - w_grid).max() < 1e-3 or np.all(ours >= best * (1 - 1e-9))


def test_fusion_of_identical_estimates_is_the_estimate():
    R = np.array([[4.0, 1.0], [1.0, 2.0]])
    mu, P, _ = covariance_intersection(np.array([1.0, 2.0]), R, np.array([1.0, 2.0]), R)
    np.testing.assert_allclose(mu, [1.0, 2.0])
    np.testing.assert_allclose(P, R, rtol=1e-12)


def test_much_tighter_estimate_dominates():
    mu, P, w = covariance_intersection(np.zeros(2), np.eye(2) * 0.01, np.ones(2) * 10, np.eye(2) * 100.0)
    assert w == pytest.approx(1.0) and np.allclose(mu, 0.0) and np.allclose(P, np.eye(2) * 0.01)


def test_ci_covers_the_true_error_for_any_cross_correlation():
    """For errors with any admissible cross-covariance C, P − cov(fused error) is PSD (CI's guarantee)."""
    rng = np.random.default_rng(2)
    R1, R2 = _random_spd(rng, 50), _random_spd(rng, 50)
    _, P, w = covariance_intersection(np.zeros((50, 2)), R1, np.zeros((50, 2)), R2)
    K1 = P @ (w[:, None, None] * np.linalg.inv(R1))
    K2 = P @ ((1 - w[:, None, None]) * np.linalg.inv(R2))
    S1, S2 = np.linalg.cholesky(R1), np.linalg.cholesky(R2)
    for rho in (-1.0, -0.5, 0.0, 0.7, 1.0):
        U, _, Vt = np.linalg.svd(rng.normal(size=(50, 2, 2)))
        C = S1 @ (rho * U @ Vt) @ np.swapaxes(S2, -1, -2)  # any contraction between the factors
        cov = (K1 @ R1 @ np.swapaxes(K1, -1, -2) + K2 @ R2 @ np.swapaxes(K2, -1, -2)
               + K1 @ C @ np.swapaxes(K2, -1, -2) + K2 @ np.swapaxes(C, -1, -2) @ np.swapaxes(K1, -1, -2))
        gap = np.linalg.eigvalsh(P - 0.5 * (cov + np.swapaxes(cov, -1, -2)))
        assert gap.min() > -1e-9 * np.abs(P).max(), rho


def test_batched_equals_single():
    rng = np.random.default_rng(3)
    R1, R2 = _random_spd(rng, 5), _random_spd(rng, 5)
    m1, m2 = rng.normal(size=(5, 2)), rng.normal(size=(5, 2))
    mu, P, w = covariance_intersection(m1, R1, m2, R2)
    for i in range(5):
        mi, Pi, wi = covariance_intersection(m1[i], R1[i], m2[i], R2[i])
        np.testing.assert_allclose(mu[i], mi)
        np.testing.assert_allclose(P[i], Pi)
        assert w[i] == pytest.approx(wi)
