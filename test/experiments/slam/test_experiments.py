
import numpy as np
import pytest

from track_core.slam import HybridParams, victoria
from track_core.slam.profiles import loop_sim_params
from track_core.slam.sim import LoopWorld, simulate
from track_experiments.cli import RunConfig
from track_experiments.slam.experiments import (
    FAIL_M,
    anees_band,
    run_loop_once,
    scans_discarded,
    slam_loop,
    victoria_park,
)


@pytest.mark.skipif(not victoria.data_dir().is_dir(), reason='Victoria Park data not available')
def test_victoria_park_quick(tmp_path):
    out = victoria_park(RunConfig(quick=True, out=tmp_path, show_progress=False))
    assert set(out.data) == {'gps_rmse_m', 'landmarks', 'pf_switches', 'runtime_s', 'duration_s'}
    assert out.data['gps_rmse_m'] < 5.0 and out.data['landmarks'] > 20
    assert all(f.exists() for f in out.figures)


@pytest.mark.skipif(not victoria.data_dir().is_dir(), reason='Victoria Park data not available')
@pytest.mark.parametrize('motion', ['increments', 'twist'])
def test_victoria_park_through_the_standard_inputs_gives_the_same_path(tmp_path, motion):
    out = victoria_park(RunConfig(quick=True, out=tmp_path, show_progress=False,
                                  options={'inputs': 'both', 'motion': motion}))
    assert out.data['path_diff_max_m'] < 1e-6
    assert out.data['gps_rmse_standard_m'] == pytest.approx(out.data['gps_rmse_m'], abs=1e-6)
    assert out.data['landmarks_standard'] == out.data['landmarks']


def test_loop_world_hybrid_recovers_where_ekf_fails():
    w = LoopWorld()
    loop_sim_params(w)
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


def test_the_switch_discards_no_scan_and_starts_the_pf_on_a_poor_one():
    w = LoopWorld()
    run = simulate(w, np.random.default_rng(0))
    r = run_loop_once(w, run, True, np.random.default_rng(11))
    to_pf = [e for e in r['events'] if e.kind == 'to_pf']
    assert to_pf and r['final_err'] < FAIL_M
    assert r['scans'] == len(run.scans) and scans_discarded(r) == 0
    # in Fig. 1 the first trunk of the start area comes into view alone: that scan starts the PF
    ts = {round(t, 6): z for t, z, _ in run.scans}
    assert ts[round(to_pf[0].t, 6)].shape[0] < 3


def test_slam_loop_quick_uses_every_scan_and_the_hybrid_is_consistent(tmp_path):
    out = slam_loop(RunConfig(quick=True, out=tmp_path, show_progress=False))
    d = out.data
    assert d['scans_discarded'] == 0 and d['hybrid_success_rate'] == 1.0
    lo, hi = anees_band(4, 3)          # --quick: 4 runs
    assert (lo, hi) == pytest.approx(tuple(d['anees_band']))
    assert lo <= d['anees_hybrid'] <= hi, d['anees_hybrid']
    assert d['anees_ekf'] > d['anees_hybrid']
