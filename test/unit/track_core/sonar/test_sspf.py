import numpy as np
import pytest
from scipy.stats import multivariate_normal

from track_core.filters import kf_predict, kf_update, mixture_mean_cov
from track_core.sonar import (
    SSPF,
    FixedScheduler,
    Scenario,
    SensorMode,
    SonarParams,
    make_tracker,
    measure,
    rb_ukf,
    residual,
    run_once,
)


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


@pytest.mark.parametrize(('alpha', 'beta', 'kappa'), [(1.0, 2.0, 0.0), (0.5, 2.0, 1.0)])
def test_rb_ukf_with_linear_measurement_is_the_kalman_filter(alpha, beta, kappa):
    # Algorithm 2 with a linear h: prediction + unscented update == kf_predict + kf_update to 1e-9
    p = SonarParams(ukf_alpha=alpha, ukf_beta=beta, ukf_kappa=kappa)
    rng = np.random.default_rng(11)
    x = np.array([300.0, 12.0, 300.0, -12.0]) + rng.normal(size=(20, 4))
    A = rng.normal(size=(20, 4, 4))
    P = A @ np.swapaxes(A, -1, -2) + np.diag([25.0, 1, 25, 1])
    H = np.array([[1.0, 0.3, 0, 0], [0, 0, 1.0, -0.2]])
    R = np.array([[4.0, 0.5], [0.5, 9.0]])
    z = np.array([305.0, 290.0])
    xu, Pu = rb_ukf(x, P, z, 'active', np.zeros(2), p, h=lambda s: s @ H.T, R=R)
    xp, Pp = kf_predict(x, P, p.F, p.Q)
    xk, Pk, _, _ = kf_update(xp, Pp, np.broadcast_to(z, (20, 2)), H, R)
    np.testing.assert_allclose(xu, xk, atol=1e-9, rtol=0)
    np.testing.assert_allclose(Pu, Pk, atol=1e-9, rtol=0)
    with pytest.raises(ValueError, match='needs its noise covariance R'):
        rb_ukf(x, P, z, 'active', np.zeros(2), p, h=lambda s: s @ H.T)


@pytest.mark.parametrize('proposal', ['transition', 'propagated'])
def test_importance_weights_equal_brute_force_densities(proposal):
    """Algorithm 3's w ∝ w_prev · p(z|x) p(x|x_prev) / q(x), each density evaluated by scipy."""
    p = SonarParams(n_particles=64)
    obs = np.array([10.0, -20.0])
    m0, P0 = np.array([300.0, 12.25, 300.0, -12.25]), np.diag([400.0, 4, 400, 4])
    # a tiny resample threshold carries the weights, so they can be read back after each step
    f = SSPF(p, FixedScheduler('active'), np.random.default_rng(7), proposal=proposal, resample_threshold=1e-9)
    f.initialize(m0, P0)
    mvn = multivariate_normal.logpdf

    def check(log_prior_w, x_prev, P_prev, z, mode):
        f.step(z, mode, obs)
        x = f.particles
        R = p.R(mode)
        log_lik = np.array([mvn(residual(z, measure(xi, obs, mode)), np.zeros(len(z)), R) for xi in x])
        if x_prev is None:  # first step: the exact predicted prior and one UKF on the prior
            xt, Pt = rb_ukf(m0[None], P0[None], z, mode, obs, p)
            log_tr = np.array([mvn(xi, p.F @ m0, p.F @ P0 @ p.F.T + p.Q) for xi in x])
            log_q = np.array([mvn(xi, xt[0], Pt[0]) for xi in x])
        else:
            xt, Pt = rb_ukf(x_prev, P_prev, z, mode, obs, p)
            log_tr = np.array([mvn(xi, p.F @ xp, p.Q) for xi, xp in zip(x, x_prev, strict=True)])
            log_q = np.array([mvn(xi, m, C) for xi, m, C in zip(x, xt, Pt, strict=True)])
        lw = log_prior_w + log_lik + log_tr - log_q
        w = np.exp(lw - lw.max())
        np.testing.assert_allclose(f.weights, w / w.sum(), rtol=1e-8, atol=1e-14)
        assert 1.0 < f.estimate.ess < 64.0

    check(np.zeros(64), None, None, np.array([0.80, 420.0]), 'active')
    w1, x1, P1 = np.log(f.weights), f.particles.copy(), f.P.copy()
    check(w1, x1, P1, np.array([0.81]), 'passive')


def _two_mode_run(seed, **kw):
    """Two modes on one bearing line (300 m and 600 m, moving along it): bearings cannot tell them apart."""
    from track_core.filters import bimodality_coefficient

    p = SonarParams()
    rng = np.random.default_rng(seed)
    f = make_tracker('papf', p, rng, **kw)
    u = np.array([np.sin(np.pi / 4), np.cos(np.pi / 4)])
    m = np.array([[300 * u[0], 3 * u[0], 300 * u[1], 3 * u[1]], [600 * u[0], 3 * u[0], 600 * u[1], 3 * u[1]]])
    f.initialize_mixture(m, np.diag([100.0, 1, 100, 1]))
    bc = []
    for _ in range(20):
        f.step(np.array([np.pi / 4 + p.sigma_b * rng.standard_normal()]), 'passive', np.zeros(2))
        bc.append(bimodality_coefficient(f.particles, f.weights))
    return np.array(bc), f


@pytest.mark.parametrize('seed', [10, 11, 12])
def test_a_two_mode_prior_keeps_two_modes(seed):
    # Sarle's coefficient of the component means: 1/3 Gaussian, 5/9 uniform, 1 two point masses.
    bc, f = _two_mode_run(seed)
    assert f.moves == 0 and bc.min() > 5 / 9
    # both modes keep particles and weight (their shares drift with the bearing noise)
    w = np.full(f.n, 1 / f.n) if f.weights is None else f.weights
    near = np.hypot(f.particles[:, 0], f.particles[:, 2]) < 450
    assert 0.05 < w[near].sum() < 0.95
    # the old rule (a Liu–West move after every selection) Gaussianises the mixture: the test can fail
    bc_old, f_old = _two_mode_run(seed, move_threshold=1.0)
    assert f_old.moves == 20 and bc_old[-5:].mean() < 0.45


def test_degenerate_selection_still_moves():
    # an active fix on a wide prior leaves few heavy particles: ESS < N/2, so the move runs
    f = make_tracker('acpf', SonarParams(), np.random.default_rng(0))
    f.initialize(np.array([300.0, 12.25, 300.0, -12.25]), np.diag([150.0**2, 4, 150.0**2, 4]))
    est = f.step(np.array([np.pi / 4, 424.0]), 'active', np.zeros(2))
    assert est.ess < 0.5 * f.n and f.moved and f.moves == 1


def test_initialize_mixture_errors():
    f = SSPF(rng=np.random.default_rng(0), proposal='transition')
    with pytest.raises(ValueError, match="needs proposal='rb'"):
        f.initialize_mixture(np.zeros((2, 4)), np.eye(4))
    f = SSPF(rng=np.random.default_rng(0))
    with pytest.raises(ValueError, match='mixture weights'):
        f.initialize_mixture(np.zeros((2, 4)), np.eye(4), np.array([1.0, -1.0]))
    with pytest.raises(ValueError, match=r'^move_threshold must be'):
        SSPF(move_threshold=0.0)


def test_bootstrap_weights_are_the_likelihood_of_transition_draws():
    p = SonarParams(n_particles=500)
    f = SSPF(p, FixedScheduler('active'), np.random.default_rng(3), proposal='bootstrap', resample_threshold=1e-9)
    m0 = np.array([300.0, 12.25, 300.0, -12.25])
    f.initialize(m0, np.diag([400.0, 4, 400, 4]))
    x0 = f.particles.copy()
    z, obs = np.array([0.80, 420.0]), np.array([10.0, -20.0])
    f.step(z, 'active', obs)
    # the draws are F x0 + Q noise: their residuals have the covariance Q
    d = f.particles - x0 @ p.F.T
    np.testing.assert_allclose(np.cov(d.T), p.Q, atol=0.25)
    lw = multivariate_normal.logpdf(residual(z, measure(f.particles, obs, 'active')), np.zeros(2), p.R('active'))
    w = np.exp(lw - lw.max())
    np.testing.assert_allclose(f.weights, w / w.sum(), rtol=1e-8, atol=1e-14)
    assert f.P is None  # no per-particle covariance: O(N) memory


def test_large_bootstrap_agrees_with_the_ukf_on_the_papers_scenario():
    # near-Gaussian posterior (AcPF): 20 000 bootstrap particles and one UKF give the same track
    from track_core.sonar import make_ukf

    sc = Scenario(n_steps=20)
    rng = np.random.default_rng(8)
    truth = sc.simulate_truth(rng)
    prior = sc.draw_prior_mean(rng, truth[0])
    noise = rng.standard_normal((20, 2))
    boot = run_once(sc, make_tracker('acpf', SonarParams(n_particles=20_000), np.random.default_rng(9),
                                     proposal='bootstrap'), truth, prior, noise)
    ukf = run_once(sc, make_ukf('acpf', sc.params), truth, prior, noise)
    gap = np.hypot(*(boot.mean - ukf.mean)[:, [0, 2]].T)
    assert gap.max() < 2.0, gap  # metres, against a position std of about 4 m
    np.testing.assert_allclose(np.sqrt(boot.cov[:, 0, 0]), np.sqrt(ukf.cov[:, 0, 0]), rtol=0.25)


def _cv_readings(n_steps, mode, start=None):
    p = SonarParams()
    x = np.array([300.0, 12.25, 300.0, -12.25]) if start is None else start
    out = []
    for _ in range(n_steps):
        x = p.F @ x
        out.append((x.copy(), measure(x, np.zeros(2), mode)))
    return out


def test_mixture_merges_when_identical_and_splits_when_spread_returns():
    p = SonarParams()
    fs = {m: SSPF(p, FixedScheduler('active'), np.random.default_rng(4), merge=m) for m in (True, False)}
    for f in fs.values():
        f.initialize(np.array([310.0, 12.0, 290.0, -12.5]), np.diag([400.0, 4, 400, 4]))
    active = _cv_readings(30, 'active')
    for _, z in active:
        est = {m: f.step(z, 'active', np.zeros(2)) for m, f in fs.items()}
        # merging keeps the estimate: the components it replaces are (nearly) identical
        np.testing.assert_allclose(est[True].mean, est[False].mean, atol=0.05)
        np.testing.assert_allclose(est[True].cov, est[False].cov, rtol=0.02, atol=1e-3)
    f = fs[True]
    assert f.components == 1 and f.merges == 1 and f.splits == 0 and fs[False].components == p.n_particles
    # bearings only from a fixed observer: the range spreads again, so the Gaussian is split into N
    comps = []
    for _, z in _cv_readings(40, 'passive', start=active[-1][0]):
        f.step(z[:1], 'passive', np.zeros(2))
        comps.append(f.components)
    assert f.splits >= 1 and p.n_particles in comps
    assert comps[-1] == p.n_particles  # it stays split while the range is spread


def test_no_merge_without_the_option_or_with_the_smart_model():
    from track_core.sonar import SmartTargetParams

    p = SonarParams()
    for kw in ({'merge': False}, {'target_model': SmartTargetParams()}):
        f = SSPF(p, FixedScheduler('active'), np.random.default_rng(4), **kw)
        f.initialize(np.array([310.0, 12.0, 290.0, -12.5]), np.diag([400.0, 4, 400, 4]))
        for _, z in _cv_readings(30, 'active'):
            f.step(z, 'active', np.zeros(2))
        assert f.components == p.n_particles and f.merges == 0


def test_wide_prior_is_split_finer_and_its_tails_weighted_back():
    f = SSPF(SonarParams(n_particles=4000), rng=np.random.default_rng(2))
    m0, P0 = np.array([300.0, 12.25, 300.0, -12.25]), np.diag([300.0**2, 4, 300.0**2, 4])
    f.initialize(m0, P0)
    assert f.split_for(P0) == pytest.approx((50.0 / 300.0) ** 2)
    np.testing.assert_allclose(f.P[0], f.split_for(P0) * P0)
    # means drawn wider, weighted back: the weighted mixture still has the prior's moments
    mean, cov = mixture_mean_cov(f.particles, f.P, f.weights)
    np.testing.assert_allclose(mean[[0, 2]], m0[[0, 2]], atol=25.0)
    np.testing.assert_allclose(np.sqrt(np.diag(cov)), np.sqrt(np.diag(P0)), rtol=0.1)
    assert np.std(f.particles[:, 0]) > 1.2 * 300.0  # the draws reach further than the prior
    # the paper's 20 m prior: b = 0.25 and equal weights, as before
    f.initialize(m0, np.diag([400.0, 4, 400, 4]))
    assert f.split_for(np.diag([400.0, 4, 400, 4])) == 0.25 and f.weights is None
    with pytest.raises(ValueError, match=r'^prior_inflation must be'):
        SSPF(prior_inflation=0.5)


def test_smart_prediction_is_unscented_and_linear_for_a_naive_target():
    from track_core.sonar import SmartTargetParams

    p, x0, P0 = SonarParams(), np.array([310.0, 12.0, 290.0, -12.5]), np.diag([400.0, 4, 400, 4])
    runs = {}
    for model in (SmartTargetParams(naive=True), SmartTargetParams()):
        for pred in ('unscented', 'linear'):
            f = SSPF(p, FixedScheduler('active'), np.random.default_rng(5), target_model=model, prediction=pred)
            f.initialize(x0, P0)
            for _, z in _cv_readings(8, 'active'):
                f.step(z, 'active', np.zeros(2))
            runs[model.naive, pred] = f.estimate
    # eq. 1 is linear: the unscented prediction is F P Fᵀ + Q exactly
    np.testing.assert_allclose(runs[True, 'unscented'].mean, runs[True, 'linear'].mean, atol=1e-8)
    np.testing.assert_allclose(runs[True, 'unscented'].cov, runs[True, 'linear'].cov, atol=1e-7)
    # the manoeuvre is not: the two predictions differ
    assert not np.allclose(runs[False, 'unscented'].cov, runs[False, 'linear'].cov, atol=1e-3)
    with pytest.raises(ValueError, match='prediction must be one of'):
        SSPF(p, prediction='ekf')


def test_a_wide_prior_carries_its_weights_until_they_degenerate():
    m0, wide, narrow = np.array([300.0, 12.25, 300.0, -12.25]), np.diag([300.0**2, 4, 300.0**2, 4]), np.diag(
        [400.0, 4, 400, 4])
    f = SSPF(SonarParams(), FixedScheduler('passive'), np.random.default_rng(3))
    f.initialize(m0, wide)
    assert f.resample_threshold == 0.5
    assert 1.0 / np.sum(f.weights**2) > 0.5 * f.n  # the prior's weights alone do not trigger a selection
    every = SSPF(SonarParams(), FixedScheduler('passive'), np.random.default_rng(3), resample_threshold=1.0)
    every.initialize(m0, wide)  # an explicit value holds whatever the prior
    assert every.resample_threshold == 1.0
    carried = 0
    for k in range(1, 6):
        obs = np.array([10.0 * k, 0.0])
        z = np.array([np.arctan2(300.0 + 12.25 * k - obs[0], 300.0 - 12.25 * k)])
        est = f.step(z, 'passive', obs)
        every.step(z, 'passive', obs)
        # selected only when ESS < N/2; otherwise the weights carry the prior ratio and the likelihoods
        assert (est.ess >= 0.5 * f.n) == (f.weights is not None)
        assert every.weights is None
        carried += f.weights is not None
    assert carried > 0
    f.initialize(m0, narrow)  # the paper's prior: selection at every step, as Algorithm 3
    assert f.resample_threshold == 1.0


def test_predict_only_steps_compose_and_leave_the_weights_alone():
    """Two predict-only steps over 0.4 s and 0.9 s are one over 1.3 s (eqs. 3-4 compose); counted; no draw."""
    from track_core.sonar import Scenario, SonarParams, make_tracker

    p = SonarParams()
    trks = [make_tracker('ss-pf', p, np.random.default_rng(3)) for _ in range(2)]
    for trk in trks:
        trk.initialize(np.array([300.0, 12.0, 300.0, -12.0]), Scenario(params=p).prior_cov)
    state = trks[0].rng.bit_generator.state
    trks[0].predict(0.4)
    trks[0].predict(0.9)
    trks[1].predict(1.3)
    np.testing.assert_allclose(trks[0].particles, trks[1].particles, rtol=1e-12)
    np.testing.assert_allclose(trks[0].P, trks[1].P, rtol=1e-9, atol=1e-9)
    assert trks[0].predictions == 2 and trks[0].t == 1.3 and trks[0].rng.bit_generator.state == state
    with pytest.raises(ValueError, match='dt'):
        trks[0].predict(-1.0)
