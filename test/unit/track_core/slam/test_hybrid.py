import logging

import numpy as np

from track_core.slam.experiments import loop_params, run_loop_once
from track_core.slam.hybrid import HybridParams, HybridSlam
from track_core.slam.sim import LoopWorld, simulate


def test_bad_input_and_backwards_time(caplog):
    h = HybridSlam(np.zeros(3), np.eye(3) * 1e-4, np.random.default_rng(0))
    assert h.process_input(0.0, 1.0, 0.0)
    assert h.process_input(1.0, 1.0, 0.0)
    x = h.pose.copy()
    with caplog.at_level(logging.WARNING):
        assert not h.process_input(0.5, 1.0, 0.0)
        assert not h.process_scan(0.5, np.array([[5.0, 1.0]]))
        np.testing.assert_array_equal(h.pose, x)
        z = np.array([[-1.0, 1.0], [np.nan, 1.0], [5.0, 4.0], [10.0, 1.5]])
        assert h.process_scan(10.0, z)
    assert h.n_dropped == 3 and h.cekf.n_landmarks == 1
    assert any('invalid' in r.message for r in caplog.records)


def test_loop_world_hybrid_recovers_where_ekf_fails():
    w = LoopWorld()
    loop_params(w)
    wins = 0
    for seed in (0, 2):
        run = simulate(w, np.random.default_rng(seed))
        e = run_loop_once(w, run, False, np.random.default_rng(10))
        h = run_loop_once(w, run, True, np.random.default_rng(11))
        assert h['pf_scans'] and h['final_err'] < 3.0
        wins += e['final_err'] > 3.0
        assert any(ev.kind == 'to_pf' for ev in h['events'])
    assert wins >= 1
    assert HybridParams().enabled


def _state(h):
    x, P = h.cekf.mean_cov()
    return x, P, h.t, h.pose.copy(), h.pose_cov.copy(), h.u.copy()


def test_backwards_or_nonfinite_time_leaves_the_whole_state_untouched(caplog):
    rng = np.random.default_rng(0)
    h = HybridSlam(np.zeros(3), np.eye(3) * 1e-4, rng)
    h.process_input(0.0, 2.0, 0.05)
    h.process_scan(0.5, np.array([[10.0, 1.2], [15.0, 2.0]]))
    h.process_input(0.6, 2.0, 0.1)
    h.process_input(1.0, 2.5, 0.1)           # pending (batched) prediction up to t = 1.0
    before = _state(h)
    with caplog.at_level(logging.WARNING):
        assert not h.process_input(0.9, 9.0, 0.3)
        assert not h.process_scan(0.99, np.array([[11.0, 1.2]]))
        assert not h.process_input(float('nan'), 1.0, 0.0)
        assert not h.process_input(1.1, float('inf'), 0.0)
    after = _state(h)
    for a, b in zip(before, after, strict=True):
        np.testing.assert_array_equal(a, b)
    assert h.cekf.n_landmarks == 2
    assert any('earlier' in r.message for r in caplog.records)
    # equal time stamps are accepted (a scan and an input may share one)
    assert h.process_input(1.0, 2.5, 0.1)


def test_valid_observations_is_a_core_function():
    from track_core.slam.hybrid import filter_observations, valid_observations

    z = np.array([[5.0, 0.0], [5.0, np.pi], [0.0, 1.0], [-2.0, 1.0], [np.nan, 1.0], [5.0, np.inf],
                  [5.0, -0.1], [5.0, 3.2], [7.5, 1.5]])
    np.testing.assert_array_equal(valid_observations(z), [1, 1, 0, 0, 0, 0, 0, 0, 1])
    ok, dropped = filter_observations(z)
    assert dropped == 6 and ok.shape == (3, 2)
    np.testing.assert_array_equal(valid_observations(z, (0.0, 3.3))[7], True)
    assert valid_observations(np.zeros((0, 2))).shape == (0,)


def test_detector_holds_scans_too_poor_to_start_the_pf():
    w = LoopWorld()
    run = simulate(w, np.random.default_rng(0))
    r = run_loop_once(w, run, True, np.random.default_rng(11))
    to_pf = [e for e in r['events'] if e.kind == 'to_pf']
    assert to_pf
    # the PF was started from a scan with at least min_init_obs observations
    ts = {round(t, 6): z for t, z, _ in run.scans}
    assert all(ts[round(e.t, 6)].shape[0] >= HybridParams().min_init_obs for e in to_pf)
