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
