import numpy as np
import pytest

from track_core.slam.association import associate
from track_core.slam.cekf import CekfSlam, SlamParams
from track_core.slam.experiments import cekf_equivalence
from track_core.slam.models import observe, vehicle_step


def test_cekf_equals_full_ekf_after_global_update():
    assert cekf_equivalence(100, 400, seed=3) < 1e-9


def test_cekf_runs_with_a_passive_part_and_matches_step_by_step():
    rng = np.random.default_rng(4)
    lm = rng.uniform(-120, 120, (150, 2))
    sp = SlamParams(max_range=30, local_radius=50, local_exit=15)
    pose = np.zeros(3)
    e = CekfSlam(pose, np.eye(3) * 1e-4, sp, compressed=False)
    c = CekfSlam(pose, np.eye(3) * 1e-4, sp, compressed=True)
    passive_seen = False
    for k in range(600):
        u = np.array([3.0, 0.1 * np.sin(k / 40)])
        pose = vehicle_step(pose, u, 0.1)
        um = u + rng.normal(0, [0.3, 0.02])
        e.predict(um, 0.1)
        c.predict(um, 0.1)
        zz = observe(pose, lm)
        vis = np.flatnonzero((zz[:, 0] < 30) & (zz[:, 1] >= 0) & (zz[:, 1] <= np.pi))
        z = zz[vis] + rng.normal(0, [0.3, 0.01], (vis.size, 2))
        ae, ac = e.update(z), c.update(z)
        np.testing.assert_array_equal(ae.obs, ac.obs)
        np.testing.assert_array_equal(ae.new, ac.new)
        passive_seen |= c.b_idx.size > 0
        np.testing.assert_allclose(c.pose, e.pose, atol=1e-9)
    assert passive_seen and c.n_global_updates > 5
    xe, Pe = e.mean_cov()
    xc, Pc = c.mean_cov()
    assert np.abs(xe - xc).max() < 1e-9 and np.abs(Pe - Pc).max() < 1e-9
    assert np.linalg.norm(xe[:2] - pose[:2]) < 5.0


def test_association_gate_nearest_and_ambiguity():
    R = np.diag([0.01, 1e-4])
    zhat = np.array([[10.0, 1.0], [10.0, 1.1], [20.0, 2.0]])
    lm = np.array([[0.0, 0.0], [1.0, 0.0], [20.0, 0.0]])
    S_small = np.tile(np.eye(2) * 1e-6, (3, 1, 1))
    z = np.array([[10.0, 1.0], [20.05, 2.0], [5.0, 0.2]])
    a = associate(z, zhat, S_small, R, lm)
    assert list(a.obs) == [0, 1] and list(a.lm) == [0, 2] and list(a.new) == [2]
    assert not a.ambiguous and not a.risk
    S_big = np.tile(np.diag([4.0, 0.05]), (3, 1, 1))
    a = associate(z, zhat, S_big, R, lm, min_separation=0.5)
    assert a.ambiguous and a.risk and a.n_candidates[0] >= 2


def test_bad_parameters():
    with pytest.raises(ValueError, match='local_radius'):
        SlamParams(local_radius=10.0)
    with pytest.raises(ValueError, match='sigma_r'):
        SlamParams(sigma_r=-1.0)
