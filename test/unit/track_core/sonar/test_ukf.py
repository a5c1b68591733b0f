import numpy as np
import pytest

from track_core.sonar import Scenario, SmartTargetParams, make_ukf, run_once
from track_core.sonar.smart_target import SmartTarget


def _inputs(sc, seed):
    rng = np.random.default_rng(seed)
    truth = sc.simulate_truth(rng)
    return truth, sc.draw_prior_mean(rng, truth[0]), rng.standard_normal((sc.n_steps, 2))


def test_smart_model_of_a_naive_target_is_the_cv_ukf():
    # naive=True makes evasive_transition eq. 1, so both hypotheses are the CV prediction
    sc = Scenario(n_steps=20)
    truth, prior, noise = _inputs(sc, 2)
    a = run_once(sc, make_ukf('ss-pf', sc.params, delta=50.0), truth, prior, noise)
    b = run_once(sc, make_ukf('ss-pf', sc.params, delta=50.0, target_model=SmartTargetParams(naive=True)),
                 truth, prior, noise)
    assert np.array_equal(a.active, b.active)
    np.testing.assert_allclose(b.mean, a.mean, atol=1e-9)
    np.testing.assert_allclose(b.cov, a.cov, atol=1e-9)


def test_evade_probability_follows_pings_and_the_quiet_period():
    sc = Scenario()
    p = sc.params
    deaf = make_ukf('acpf', p, target_model=SmartTargetParams(p_max=0.0))
    aware = make_ukf('acpf', p, target_model=SmartTargetParams(quiet_period=5.0))
    passive = make_ukf('papf', p, target_model=SmartTargetParams())
    tgt = SmartTarget(np.array(sc.target_x0), sonar=p, params=SmartTargetParams(p_max=0.0))
    rng = np.random.default_rng(0)
    for t in (deaf, aware, passive):
        t.initialize(tgt.x, sc.prior_cov)
    pe = []
    for k in range(12):
        obs = sc.observer.position(sc.times[k])
        tgt.step(rng, False, obs)
        for t in (deaf, aware, passive):
            z = np.array([np.arctan2(tgt.x[0] - obs[0], tgt.x[2] - obs[1]), np.hypot(tgt.x[0] - obs[0],
                                                                                     tgt.x[2] - obs[1])])
            t.step(z if t is not passive else z[:1], t.next_mode, obs)
        pe.append(aware.p_evade)
        assert deaf.p_evade == 0.0 and passive.p_evade == 0.0
    # pinged every step at ~400 m (P_det ≈ 0.8): the prior says evading; the cruising truth argues back
    assert 0.0 < pe[1] < 1.0
    assert all(np.isfinite(pe))


def test_stonesoup_peer_has_no_smart_model():
    with pytest.raises(ValueError, match="target_model needs peer='ukf'"):
        make_ukf('ss-pf', peer='stonesoup-ukf', target_model=SmartTargetParams())


def test_the_ukf_peer_takes_any_interval_and_predict_only_steps_like_the_ss_pf():
    """Eqs. 3-4 compose: two predictions over 0.4 s and 0.9 s are one over 1.3 s; dt = T and Table 1's R
    are the default step, bit for bit."""
    from track_core.sonar import Scenario, SensorMode, SonarParams
    from track_core.sonar.ukf import make_ukf

    p = SonarParams()
    a, b, c = (make_ukf('ss-pf', p) for _ in range(3))
    for trk in (a, b, c):
        trk.initialize(np.array([300.0, 12.0, 300.0, -12.0]), Scenario(params=p).prior_cov)
    a.predict(0.4)
    a.predict(0.9)
    b.predict(1.3)
    np.testing.assert_allclose(a.x, b.x, rtol=1e-12)
    np.testing.assert_allclose(a.P, b.P, rtol=1e-9)
    assert a.predictions == 2 and a.k == 2
    z = np.array([0.8, 420.0])
    e1 = c.step(z, SensorMode.ACTIVE, np.zeros(2))
    d = make_ukf('ss-pf', p)
    d.initialize(np.array([300.0, 12.0, 300.0, -12.0]), Scenario(params=p).prior_cov)
    e2 = d.step(z, SensorMode.ACTIVE, np.zeros(2), dt=p.T, R=p.R(SensorMode.ACTIVE))
    np.testing.assert_array_equal(e1.mean, e2.mean)
