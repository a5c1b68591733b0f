import numpy as np
import pytest

from track_core.geofeasibility import ellipse_to_gaussian, gaussian_to_ellipse


def test_phi_is_the_bearing_of_the_rx_axis_clockwise_from_north():
    # φ = 0: r_x along north (y); φ = π/2: r_x along east (x)
    _, R = ellipse_to_gaussian(0.0, 0.0, 4.0, 2.0, 0.0)
    np.testing.assert_allclose(R, np.diag([1.0, 4.0]))
    _, R = ellipse_to_gaussian(0.0, 0.0, 4.0, 2.0, np.pi / 2)
    np.testing.assert_allclose(R, np.diag([4.0, 1.0]), atol=1e-15)
    # bearing 45°: major axis along north-east (1, 1)/√2
    _, R = ellipse_to_gaussian(0.0, 0.0, 4.0, 2.0, np.pi / 4)
    w, v = np.linalg.eigh(R)
    assert w[-1] == pytest.approx(4.0) and abs(v[0, -1]) == pytest.approx(abs(v[1, -1]))
    assert v[0, -1] * v[1, -1] > 0


def test_eq56_reflection_gives_the_same_covariance_as_the_rotation():
    phi = 0.83
    s, c = np.sin(phi), np.cos(phi)
    U = np.array([[s, c], [c, -s]])
    assert np.linalg.det(U) == pytest.approx(-1.0)
    L = np.diag([9.0 / 4, 1.0 / 4])
    rot = U @ np.diag([1.0, -1.0])
    assert np.linalg.det(rot) == pytest.approx(1.0)
    np.testing.assert_allclose(U @ L @ U.T, rot @ L @ rot.T)
    _, R = ellipse_to_gaussian(1.0, 2.0, 3.0, 1.0, phi)
    np.testing.assert_allclose(R, U @ L @ U.T)


def test_2sigma_ellipse_boundary_points_are_at_mahalanobis_2():
    mu, R = ellipse_to_gaussian(3.0, -1.0, 5.0, 2.0, 0.4)
    tip = mu + 5.0 * np.array([np.sin(0.4), np.cos(0.4)])      # end of the r_x axis
    side = mu + 2.0 * np.array([np.cos(0.4), -np.sin(0.4)])    # end of the r_y axis
    for p in (tip, side):
        d = p - mu
        assert d @ np.linalg.solve(R, d) == pytest.approx(4.0)


def test_round_trip_ellipse_gaussian_ellipse_canonical():
    rng = np.random.default_rng(0)
    n = 1000
    ry = rng.uniform(0.1, 5.0, n)
    rx = ry * rng.uniform(1.0001, 100.0, n)       # canonical: r_x ≥ r_y
    phi = rng.uniform(0.0, np.pi, n)
    x0, y0 = rng.normal(size=(2, n)) * 100
    back = gaussian_to_ellipse(*ellipse_to_gaussian(x0, y0, rx, ry, phi))
    for a, b in zip(back, (x0, y0, rx, ry, phi), strict=True):
        assert a == pytest.approx(b, rel=1e-9, abs=1e-9)


def test_round_trip_gaussian_ellipse_gaussian():
    rng = np.random.default_rng(1)
    A = rng.normal(size=(500, 2, 2))
    R = A @ np.swapaxes(A, 1, 2) + 0.01 * np.eye(2)
    mu = rng.normal(size=(500, 2))
    mu2, R2 = ellipse_to_gaussian(*gaussian_to_ellipse(mu, R))
    assert mu2 == pytest.approx(mu)
    np.testing.assert_allclose(R2, R, rtol=1e-10, atol=1e-12)


def test_non_canonical_input_maps_to_canonical_form():
    # r_x < r_y at bearing φ is the same ellipse as r_x, r_y swapped at φ + 90°
    _, _, rx, ry, phi = gaussian_to_ellipse(*ellipse_to_gaussian(0, 0, 1.0, 3.0, 0.2))
    assert (rx, ry) == pytest.approx((3.0, 1.0))
    assert phi == pytest.approx(0.2 + np.pi / 2)
    _, _, rx, ry, phi = gaussian_to_ellipse(*ellipse_to_gaussian(0, 0, 2.0, 2.0, 1.0))
    assert (rx, ry, phi) == pytest.approx((2.0, 2.0, 0.0))


@pytest.mark.parametrize('bad', [(0, 0, 0.0, 1.0, 0.0), (0, 0, 1.0, -1.0, 0.0), (0, 0, 1.0, 1.0, np.nan),
                                 (np.inf, 0, 1.0, 1.0, 0.0)])
def test_bad_ellipse_parameters_raise(bad):
    with pytest.raises(ValueError):
        ellipse_to_gaussian(*bad)
