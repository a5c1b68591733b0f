import numpy as np
import pytest

from track_core.filters import kf_predict, kf_update
from track_core.sonar import SSPF, Scenario, SensorMode, SonarParams, make_tracker, rb_ukf, run_once


def test_rb_ukf_batch_matches_single_and_is_vectorised():
    p = SonarParams()
    rng = np.random.default_rng(0)
    x = np.array([300.0, 12.0, 300.0, -12.0]) + rng.normal(size=(50, 4))
    P = np.broadcast_to(np.diag([25.0, 1, 25, 1]), (50, 4, 4))
    z = np.array([0.8, 430.0])
    xb, Pb = rb_ukf(x, P, z, 'active', np.zeros(2), p)
    assert xb.shape == (50, 4) and Pb.shape == (50, 4, 4)
    x3, P3 = rb_ukf(x[3:4], P[3:4], z, 'active', np.zeros(2), p)
    np.testing.assert_allclose(xb[3], x3[0], atol=1e-10)
    np.testing.assert_allclose(Pb[3], P3[0], atol=1e-10)


def test_rb_ukf_range_only_direction_close_to_ekf():
    # far target, tiny prior: the unscented update is close to the linearised Kalman update
    p = SonarParams()
    x = np.array([[0.0, 0.0, 1000.0, 0.0]])
    P = np.diag([1e-2, 1e-4, 1e-2, 1e-4])[None]
    z = np.array([0.001, 1000.5])
    xu, _ = rb_ukf(x, P, z, 'active', np.zeros(2), p)
    xp, Pp = kf_predict(x, P, p.F, p.Q)
    H = np.array([[1 / 1000.0, 0, 0, 0], [0, 0, 1, 0]])
    xk, _, _, _ = kf_update(xp, Pp, (z - np.array([0.0, 1000.0]))[None] + xp @ H.T, H, p.R('active'))
    np.testing.assert_allclose(xu, xk, atol=2e-3)


def test_same_seed_reproduces_bit_for_bit():
    sc = Scenario(n_steps=8)
    truth = sc.simulate_truth(np.random.default_rng(1))
    noise = np.random.default_rng(2).standard_normal((8, 2))
    a = run_once(sc, make_tracker('ss-pf', sc.params, np.random.default_rng(3)), truth, truth[0], noise)
    b = run_once(sc, make_tracker('ss-pf', sc.params, np.random.default_rng(3)), truth, truth[0], noise)
    assert np.array_equal(a.mean, b.mean) and np.array_equal(a.active, b.active)


def test_acpf_converges_and_papf_passive():
    sc = Scenario()
    rng = np.random.default_rng(5)
    err_a, err_p = [], []
    for _ in range(3):
        truth = sc.simulate_truth(rng)
        prior = sc.draw_prior_mean(rng, truth[0])
        noise = rng.standard_normal((40, 2))
        ra = run_once(sc, make_tracker('acpf', sc.params, rng), truth, prior, noise)
        rp = run_once(sc, make_tracker('papf', sc.params, rng), truth, prior, noise)
        assert ra.active.all() and not rp.active.any()
        err_a.append(ra.pos_err_sq[10:])
        err_p.append(rp.pos_err_sq[10:])
    assert np.sqrt(np.mean(err_a)) < 15.0
    assert np.sqrt(np.mean(err_p)) > np.sqrt(np.mean(err_a))


def test_step_interface_and_errors():
    f = SSPF(rng=np.random.default_rng(0))
    with pytest.raises(RuntimeError, match='initialize'):
        f.step([0.5], 'passive', np.zeros(2))
    f.initialize(np.array([300.0, 12.25, 300.0, -12.25]), np.diag([400.0, 4, 400, 4]))
    assert f.next_mode is SensorMode.ACTIVE
    with pytest.raises(ValueError, match='active measurement must be 2'):
        f.step([0.5], 'active', np.zeros(2))
    est = f.step(np.array([np.pi / 4, 424.0]), 'active', np.zeros(2))
    assert est.k == 1 and est.mean.shape == (4,) and est.cov.shape == (4, 4)
    assert est.next_mode in (SensorMode.ACTIVE, SensorMode.PASSIVE)
    assert np.hypot(est.mean[0] - 300, est.mean[2] - 300) < 20
    with pytest.raises(ValueError, match=r'^tracker must be'):
        make_tracker('kf')
    with pytest.raises(ValueError, match=r'^delta must be'):
        make_tracker('ss-pf', delta=-1.0)
    with pytest.raises(ValueError, match=r'^n_particles must be'):
        SonarParams(n_particles=0)
