import numpy as np
import pytest

from track_core.filters import (
    kf_predict,
    kf_update,
    sigma_points,
    unscented_predict,
    unscented_update,
    unscented_weights,
    wrap_angle,
)


def _random_cov(rng, n, batch=()):
    A = rng.normal(size=(*batch, n, n))
    return A @ np.swapaxes(A, -1, -2) + 0.5 * np.eye(n)


@pytest.mark.parametrize(('alpha', 'beta', 'kappa'), [(1.0, 2.0, 0.0), (0.5, 2.0, 1.0), (1.0, 0.0, -1.0)])
def test_linear_measurement_equals_kalman(alpha, beta, kappa):
    rng = np.random.default_rng(1)
    n, m, N = 4, 2, 7
    x = rng.normal(size=(N, n))
    P = _random_cov(rng, n, (N,))
    H = rng.normal(size=(m, n))
    R = _random_cov(rng, m)
    z = rng.normal(size=m)
    w = unscented_weights(n, alpha, beta, kappa)
    xu, Pu, nuu, Su = unscented_update(x, P, z, lambda s: s @ H.T, R, w)
    xk, Pk, nuk, Sk = kf_update(x, P, np.broadcast_to(z, (N, m)), H, R)
    np.testing.assert_allclose(xu, xk, atol=1e-9, rtol=0)
    np.testing.assert_allclose(Pu, Pk, atol=1e-9, rtol=0)
    np.testing.assert_allclose(nuu, nuk, atol=1e-9)
    np.testing.assert_allclose(Su, Sk, atol=1e-9)


@pytest.mark.parametrize(('alpha', 'beta', 'kappa'), [(1.0, 2.0, 0.0), (0.5, 2.0, 1.0)])
def test_linear_prediction_equals_kalman(alpha, beta, kappa):
    rng = np.random.default_rng(2)
    x, P = rng.normal(size=(5, 4)), _random_cov(rng, 4, (5,))
    F, Q = rng.normal(size=(4, 4)), _random_cov(rng, 4)
    mu, C = unscented_predict(x, P, lambda s: s @ F.T, Q, unscented_weights(4, alpha, beta, kappa))
    mk, Ck = kf_predict(x, P, F, Q)
    np.testing.assert_allclose(mu, mk, atol=1e-9)
    np.testing.assert_allclose(C, Ck, atol=1e-9)
    # a nonlinear f: the mean is not f of the mean
    mu2, _ = unscented_predict(x, P, lambda s: s**2, Q, unscented_weights(4))
    assert np.all(mu2 > x**2)


def test_sigma_points_reproduce_mean_and_cov():
    rng = np.random.default_rng(2)
    w = unscented_weights(4, 1.0, 2.0, 0.0)
    mean = rng.normal(size=(3, 4))
    P = _random_cov(rng, 4, (3,))
    chi = sigma_points(mean, P, w)
    assert chi.shape == (3, 9, 4)
    np.testing.assert_allclose(np.einsum('i,...ij->...j', w.wm, chi), mean, atol=1e-12)
    d = chi - mean[:, None]
    np.testing.assert_allclose(np.einsum('i,...ia,...ib->...ab', w.wc, d, d) - (w.wc[0] - w.wm[0]) * 0, P,
                               atol=1e-10)
    assert w.wm.sum() == pytest.approx(1.0)


def test_angular_residual_across_pi():
    # a bearing measurement of an object almost due south; sigma points straddle ±π
    w = unscented_weights(2)
    mean = np.array([[0.01, -100.0]])
    P = np.diag([4.0, 4.0])[None]

    def h(s):
        return np.arctan2(s[..., 0], s[..., 1])[..., None]

    def res(a, b):
        return wrap_angle(a - b)

    x, _, nu, S = unscented_update(mean, P, np.array([-np.pi + 0.001]), h, np.array([[1e-4]]), w, res)
    assert abs(nu[0, 0]) < 0.05 and S[0, 0, 0] < 0.01
    assert np.all(np.isfinite(x))


def test_bad_weights_raise():
    with pytest.raises(ValueError, match='kappa'):
        unscented_weights(4, 1.0, 2.0, -5.0)
    with pytest.raises(ValueError, match='alpha'):
        unscented_weights(4, 0.0)
