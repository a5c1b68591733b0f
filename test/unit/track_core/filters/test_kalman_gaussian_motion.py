import numpy as np
import pytest

from track_core.filters import (
    CovarianceError,
    check_covariance,
    covariance_problem,
    cv_process_noise,
    cv_transition,
    kf_predict,
    kf_update,
    mahalanobis_sq,
    symmetrize,
)


def test_cv_model_matches_closed_form():
    T, q = 0.5, 2.0
    F = cv_transition(T)
    assert F @ np.array([1.0, 2.0, 3.0, -4.0]) == pytest.approx([2.0, 2.0, 1.0, -4.0])
    Q = cv_process_noise(T, q)
    assert Q[0, 0] == pytest.approx(q * T**3 / 3) and Q[0, 1] == pytest.approx(q * T**2 / 2)
    assert Q[1, 1] == pytest.approx(q * T) and Q[0, 2] == 0.0
    assert covariance_problem(Q, definite=True) is None


@pytest.mark.parametrize(('P', 'words'), [
    (np.array([[1.0, np.nan], [np.nan, 1.0]]), 'non-finite'),
    (np.array([[1.0, 0.5], [0.0, 1.0]]), 'not symmetric'),
    (np.array([[1.0, 2.0], [2.0, 1.0]]), 'not positive semi-definite'),
    (np.ones((2, 3)), 'square'),
])
def test_covariance_problem_names_the_reason(P, words):
    reason = covariance_problem(P)
    assert reason is not None and words in reason
    with pytest.raises(CovarianceError, match='R:'):
        check_covariance(P, 'R')


def test_semidefinite_versus_definite():
    P = np.array([[1.0, 1.0], [1.0, 1.0]])  # singular, PSD
    assert covariance_problem(P) is None
    assert 'positive definite' in covariance_problem(P, definite=True)


def test_kf_update_equals_information_form():
    rng = np.random.default_rng(3)
    A = rng.normal(size=(4, 4))
    P = A @ A.T + np.eye(4)
    x = rng.normal(size=4)
    H = rng.normal(size=(2, 4))
    R = np.diag([0.5, 2.0])
    z = rng.normal(size=2)
    x1, P1, nu, S = kf_update(x, P, z, H, R)
    Pinf = np.linalg.inv(np.linalg.inv(P) + H.T @ np.linalg.inv(R) @ H)
    xinf = Pinf @ (np.linalg.inv(P) @ x + H.T @ np.linalg.inv(R) @ z)
    np.testing.assert_allclose(P1, Pinf, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(x1, xinf, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(nu, z - H @ x)
    np.testing.assert_allclose(S, H @ P @ H.T + R)


def test_kf_steps_are_batched():
    rng = np.random.default_rng(4)
    F, Q = cv_transition(1.0), cv_process_noise(1.0, 1.0)
    H = np.array([[1.0, 0, 0, 0], [0, 0, 1.0, 0]])
    x = rng.normal(size=(5, 4))
    P = np.broadcast_to(np.eye(4), (5, 4, 4)).copy()
    z = rng.normal(size=(5, 2))
    xb, Pb = kf_predict(x, P, F, Q)
    xb, Pb, _, _ = kf_update(xb, Pb, z, H, np.eye(2))
    for i in range(5):
        xi, Pi = kf_predict(x[i], P[i], F, Q)
        xi, Pi, _, _ = kf_update(xi, Pi, z[i], H, np.eye(2))
        np.testing.assert_allclose(xb[i], xi, rtol=1e-12)
        np.testing.assert_allclose(Pb[i], Pi, rtol=1e-12)


def test_mahalanobis_and_symmetrize():
    S = np.array([[4.0, 0.0], [0.0, 1.0]])
    assert mahalanobis_sq(np.array([2.0, 1.0]), S) == pytest.approx(2.0)
    assert np.array_equal(symmetrize(np.array([[1.0, 2.0], [0.0, 1.0]])), [[1.0, 1.0], [1.0, 1.0]])


def test_ellipse_points_lie_on_the_n_sigma_contour_batched():
    from track_core.filters import ellipse_points, mahalanobis_sq

    rng = np.random.default_rng(5)
    A = rng.normal(size=(4, 2, 2))
    covs = A @ np.swapaxes(A, -1, -2) + 0.1 * np.eye(2)
    means = rng.normal(size=(4, 2))
    pts = ellipse_points(means, covs, 2.0, 30)
    assert pts.shape == (4, 31, 2)
    np.testing.assert_array_equal(pts[:, 0], pts[:, -1])                 # closed
    d = pts - means[:, None, :]
    np.testing.assert_allclose(mahalanobis_sq(d, covs[:, None]), 4.0, rtol=1e-9)
    np.testing.assert_allclose(ellipse_points(means[1], covs[1], 2.0, 30), pts[1], atol=1e-12)   # single = batched
    seg = ellipse_points(np.zeros(2), np.array([[1.0, 1.0], [1.0, 1.0]]), 1.0, 8)   # singular PSD: a segment
    assert np.all(np.isfinite(seg)) and np.allclose(seg[:, 0], seg[:, 1])
