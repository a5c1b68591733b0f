import numpy as np
import pytest

from track_core.sonar import Scenario, SmartTargetParams, make_ukf, run_once
from track_core.sonar.gaussian_sum import GaussianSumUKF
from track_core.sonar.scheduler import FixedScheduler
from track_core.sonar.smart_target import SmartTarget


def _inputs(sc, seed):
    rng = np.random.default_rng(seed)
    truth = sc.simulate_truth(rng)
    return truth, sc.draw_prior_mean(rng, truth[0]), rng.standard_normal((sc.n_steps, 2))


@pytest.mark.parametrize('model', [None, SmartTargetParams(naive=True)])
def test_without_a_smart_target_it_is_the_cv_ukf(model):
    sc = Scenario(n_steps=20)
    truth, prior, noise = _inputs(sc, 3)
    a = run_once(sc, make_ukf('ss-pf', sc.params, delta=50.0), truth, prior, noise)
    b = run_once(sc, make_ukf('ss-pf', sc.params, peer='gs-ukf', delta=50.0, target_model=model), truth, prior, noise)
    assert np.array_equal(a.active, b.active)
    np.testing.assert_allclose(b.mean, a.mean, atol=1e-8)
    np.testing.assert_allclose(b.cov, a.cov, atol=1e-8)


def test_one_component_per_recent_ping_and_none_for_a_deaf_target():
    sc = Scenario()
    p = sc.params
    tgt = SmartTarget(np.array(sc.target_x0), sonar=p, params=SmartTargetParams(p_max=0.0))
    aware = GaussianSumUKF(p, FixedScheduler('active'), target_model=SmartTargetParams(quiet_period=5.0))
    deaf = GaussianSumUKF(p, FixedScheduler('active'), target_model=SmartTargetParams(p_max=0.0))
    for g in (aware, deaf):
        g.initialize(tgt.x, sc.prior_cov)
    rng = np.random.default_rng(0)
    counts = []
    for k in range(15):
        obs = sc.observer.position(sc.times[k])
        tgt.step(rng, False, obs)
        d = tgt.x[[0, 2]] - obs
        z = np.array([np.arctan2(d[0], d[1]), np.hypot(*d)])
        for g in (aware, deaf):
            g.step(z, 'active', obs)
        counts.append(aware.components)
        assert deaf.components == 1 and deaf.p_evade == 0.0
    # a ping every second, quiet period 5 s: at most 5 recent last-heard times plus 'stale'
    assert max(counts) <= 6 and max(counts) > 1
    assert 0.0 <= aware.p_evade <= 1.0 and np.isfinite(aware.estimate.mean).all()


def test_cruise_speed_is_a_state_learnt_from_the_prior():
    sc = Scenario()
    mean = np.array(sc.target_x0, float)
    est = GaussianSumUKF(sc.params, target_model=SmartTargetParams())
    fixed = GaussianSumUKF(sc.params, target_model=SmartTargetParams(), cruise='prior')
    for g in (est, fixed):
        g.initialize(mean, sc.prior_cov)
    speed = np.hypot(mean[1], mean[3])
    assert fixed.cruise_speed == speed and fixed.P.shape == (1, 4, 4)
    assert est.P.shape == (1, 5, 5) and abs(est.cruise_speed - speed) < 0.5
    assert 0.5 < est.P[0, 4, 4] < 8.0  # |v| of a prior with 2 m/s per axis
    assert np.all(np.linalg.eigvalsh(est.P[0]) > -1e-9)


def test_bad_options_are_refused():
    with pytest.raises(ValueError, match='prediction must be one of'):
        GaussianSumUKF(prediction='ekf')
    with pytest.raises(ValueError, match='cruise must be one of'):
        GaussianSumUKF(cruise='known')
