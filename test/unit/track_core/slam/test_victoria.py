import numpy as np
import pytest

from track_core.slam import victoria

pytestmark = pytest.mark.skipif(not victoria.data_dir().is_dir(), reason='Victoria Park data not available')


def test_load_prefix_and_events():
    vp = victoria.load(t_max=30.0)
    assert vp.inputs.shape[1] == 3 and len(vp.scans) == vp.scan_t.size > 10
    assert all(np.all((s[:, 1] >= 0) & (s[:, 1] <= np.pi)) for s in vp.scans)
    ts = [e[1] for e in victoria.events(vp)]
    assert np.all(np.diff(ts) >= 0)


def test_rigid_alignment_recovers_transform():
    rng = np.random.default_rng(0)
    src = rng.normal(size=(50, 2)) * 30
    th = 0.7
    R = np.array([[np.cos(th), -np.sin(th)], [np.sin(th), np.cos(th)]])
    Re, te = victoria.rigid_align(src, src @ R.T + [5.0, -3.0])
    np.testing.assert_allclose(Re, R, atol=1e-12)
    np.testing.assert_allclose(te, [5.0, -3.0], atol=1e-10)
    g = np.array([[0, 0, 0], [1, 1, 0], [2, 80, 0], [3, 3, 0]], float)
    assert list(victoria.gps_mask(g)) == [True, True, False, True]


def test_gps_nees_is_the_aligned_error_over_estimate_plus_gps_covariance():
    rng = np.random.default_rng(3)
    t = np.arange(0.0, 200.0, 1.0)
    xy = np.stack([2.0 * t, 30.0 * np.sin(t / 40.0)], 1)
    g, c = 0.4, np.cos(0.4)
    R = np.array([[c, -np.sin(g)], [np.sin(g), c]])
    gps = np.column_stack([t, xy @ R.T + [100.0, -50.0] + rng.normal(0.0, 1.0, xy.shape)])
    cov = np.broadcast_to(np.eye(2) * 0.25, (t.size, 2, 2))
    nees = victoria.gps_nees(t, xy, cov, gps, sigma_gps=1.0)
    rmse, _, kept = victoria.gps_rmse(t, xy, gps)
    assert nees.shape == (kept.shape[0],)
    # isotropic covariance 0.25 + 1: the mean NEES is the mean squared aligned error over 1.25
    assert nees.mean() == pytest.approx(rmse ** 2 / 1.25, rel=1e-9)
    # 2 dof, the true errors N(0, I) scored with σ² = 1.25 (the fitted alignment absorbs 3 of 2n dof)
    n = nees.size
    assert nees.mean() == pytest.approx(2.0 / 1.25 * (2 * n - 3) / (2 * n), abs=5 * 2 / 1.25 / np.sqrt(n))
