import numpy as np
import pytest

from track_core.slam.models import (
    VehicleParams,
    inverse_observe,
    inverse_observe_jacobians,
    observe,
    observe_jacobians,
    vehicle_jacobians,
    vehicle_step,
)


def _num_jac(f, x, eps=1e-6):
    x = np.asarray(x, float)
    cols = []
    for i in range(x.size):
        d = np.zeros_like(x)
        d[i] = eps
        cols.append((f(x + d) - f(x - d)) / (2 * eps))
    return np.stack(cols, -1)


def test_vehicle_model_straight_and_turning():
    vp = VehicleParams()
    p = vehicle_step(np.array([0.0, 0.0, 0.0]), np.array([2.0, 0.0]), 0.5, vp)
    np.testing.assert_allclose(p, [1.0, 0.0, 0.0])
    # constant steering: heading rate (v_c/L) tan α with v_c = v_e / (1 − tan α H/L)
    a = 0.2
    p = vehicle_step(np.zeros(3), np.array([1.0, a]), 1e-3, vp)
    vc = 1.0 / (1 - np.tan(a) * vp.H / vp.L)
    assert p[2] == pytest.approx(1e-3 * vc * np.tan(a) / vp.L)
    # the laser (a, b ahead/left of the rear axle) swings sideways: ẏ = (vc/L) tan α · a at φ = 0
    assert p[1] / 1e-3 == pytest.approx(vc * np.tan(a) / vp.L * vp.a)
    with pytest.raises(ValueError, match='L'):
        VehicleParams(L=0.0)


def test_vehicle_jacobians_finite_differences():
    rng = np.random.default_rng(0)
    for _ in range(5):
        x = rng.normal(size=3)
        u = np.array([rng.uniform(0.5, 5), rng.uniform(-0.4, 0.4)])
        F, G = vehicle_jacobians(x, u, 0.1)
        np.testing.assert_allclose(F, _num_jac(lambda v, u=u: vehicle_step(v, u, 0.1), x), atol=1e-7)
        np.testing.assert_allclose(G, _num_jac(lambda w, x=x: vehicle_step(x, w, 0.1), u), atol=1e-7)


def test_observation_convention_and_jacobians():
    # bearing eq. 5: π/2 straight ahead, 0 to the right
    assert observe(np.zeros(3), np.array([5.0, 0.0]))[1] == pytest.approx(np.pi / 2)
    assert observe(np.zeros(3), np.array([0.0, -5.0]))[1] == pytest.approx(0.0)
    rng = np.random.default_rng(1)
    pose, m = rng.normal(size=3), rng.normal(size=2) * 10
    Hv, Hm = observe_jacobians(pose, m)
    np.testing.assert_allclose(Hv, _num_jac(lambda v: observe(v, m), pose), atol=1e-7)
    np.testing.assert_allclose(Hm, _num_jac(lambda v: observe(pose, v), m), atol=1e-7)
    z = observe(pose, m)
    np.testing.assert_allclose(inverse_observe(pose, z), m, atol=1e-12)
    Gv, Gz = inverse_observe_jacobians(pose, z)
    np.testing.assert_allclose(Gv, _num_jac(lambda v: inverse_observe(v, z), pose), atol=1e-7)
    np.testing.assert_allclose(Gz, _num_jac(lambda v: inverse_observe(pose, v), z), atol=1e-7)


def test_scalar_step_matches_array_model():
    from track_core.slam.models import vehicle_step_scalar

    rng = np.random.default_rng(5)
    vp = VehicleParams()
    for _ in range(50):
        x = np.array([*rng.normal(size=2) * 10, rng.uniform(-np.pi, np.pi)])
        u = np.array([rng.uniform(-1, 6), rng.uniform(-0.5, 0.5)])
        dt = rng.uniform(0.001, 0.3)
        out = vehicle_step_scalar(*x, *u, dt, vp)
        F, G = vehicle_jacobians(x, u, dt, vp)
        np.testing.assert_allclose(out[:3], vehicle_step(x, u, dt, vp), atol=1e-12)
        np.testing.assert_allclose(out[3:5], F[:2, 2], atol=1e-12)
        np.testing.assert_allclose(np.reshape(out[5:], (3, 2)), G, atol=1e-12)
        # F is the identity except F[0, 2], F[1, 2] (what the batched CEKF prediction relies on)
        Fi = F.copy()
        Fi[:2, 2] = 0.0
        np.testing.assert_array_equal(Fi, np.eye(3))
    # heading wrapped to (−π, π] like wrap_angle
    out = vehicle_step_scalar(0.0, 0.0, np.pi - 1e-3, 5.0, 0.3, 0.2, vp)
    assert -np.pi < out[2] <= np.pi
    assert out[2] == pytest.approx(vehicle_step(np.array([0.0, 0.0, np.pi - 1e-3]), np.array([5.0, 0.3]), 0.2)[2])
