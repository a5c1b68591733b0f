"""``track-experiment victoria-park-smoother``: the smoother peers get exactly the filter's problem."""

import numpy as np
import pytest

from track_core.slam import victoria
from track_core.slam.cekf import CekfSlam, SlamParams
from track_core.slam.models import VehicleParams
from track_experiments.cli import RunConfig
from track_experiments.slam import smoother
from track_experiments.slam.smoother import _compose, _RelativeOdometry, victoria_smoother

needs_data = pytest.mark.skipif(not victoria.data_dir().is_dir(), reason='Victoria Park data not available')


def test_recorded_odometry_is_the_cekf_prediction():
    """The motion between two scans, integrated from the identity and composed onto the pose, equals the CEKF's
    prediction of that interval, and its covariance rotated into the map frame equals the CEKF's P."""
    rng = np.random.default_rng(1)
    sp = SlamParams()
    pose0 = np.array([3.0, -2.0, 0.7])
    f = CekfSlam(pose0, np.zeros((3, 3)), sp)
    rel = _RelativeOdometry(VehicleParams(), np.diag([sp.sigma_v ** 2, sp.sigma_steer ** 2]))
    for _ in range(40):
        u, dt = np.array([rng.uniform(1.0, 4.0), rng.uniform(-0.3, 0.3)]), rng.uniform(0.01, 0.05)
        f.predict(u, dt)
        rel.step(u, dt)
    np.testing.assert_allclose(_compose(pose0, np.array(rel.x)), f.pose, atol=1e-12)
    c, s = np.cos(pose0[2]), np.sin(pose0[2])
    Rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    np.testing.assert_allclose(Rz @ rel.Q @ Rz.T, f.pose_cov, atol=1e-15)


def test_without_gtsam_the_entry_says_why_it_skipped(tmp_path, monkeypatch):
    monkeypatch.setattr(smoother, 'gtsam_available', lambda: False)
    out = victoria_smoother(RunConfig(quick=True, out=tmp_path, show_progress=False))
    assert out.data == {'skipped': smoother.GTSAM_MISSING} and 'skipped' in out.table


@needs_data
def test_smoothers_solve_the_filters_problem_on_the_start_of_victoria_park(tmp_path):
    pytest.importorskip('gtsam')
    out = victoria_smoother(RunConfig(quick=True, out=tmp_path, show_progress=False))
    d = out.data
    # iSAM2 and batch LM reach the same optimum of the same graph
    assert d['path_diff_isam2_lm_max_m'] < 0.01
    assert d['gps_rmse_isam2_m'] == pytest.approx(d['gps_rmse_lm_m'], abs=0.01)
    # iSAM2's online path uses what the filter had at each scan: it is the filter's path, to a few mm of RMSE
    assert d['gps_rmse_isam2_online_m'] == pytest.approx(d['gps_rmse_filter_m'], abs=0.01)
    assert d['observations_fused'] > 1000 and d['landmarks_started'] > 20
    assert d['gps_rmse_dead_reckoning_m'] > d['gps_rmse_lm_m']
