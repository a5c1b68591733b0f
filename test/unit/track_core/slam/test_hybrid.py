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
