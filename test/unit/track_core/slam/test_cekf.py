import numpy as np
import pytest

from track_core.slam.association import associate
from track_core.slam.cekf import CekfSlam, SlamParams
from track_core.slam.models import observe, vehicle_step


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


def _reference_predict(x, P, u, dt, sp):
    """Textbook sequential EKF prediction on the full state (F, G from the array model)."""
    from track_core.slam.models import vehicle_jacobians

    F, G = vehicle_jacobians(x[:3], u, dt)
    Q = G @ np.diag([sp.sigma_v**2, sp.sigma_steer**2]) @ G.T + dt * np.diag(sp.q_pose)
    x = x.copy()
    x[:3] = vehicle_step(x[:3], u, dt)
    n = x.size
    Fx = np.eye(n)
    Fx[:3, :3] = F
    P = Fx @ P @ Fx.T
    P[:3, :3] += Q
    return x, P


def _mapped_filter(compressed, rng, sp):
    f = CekfSlam(np.zeros(3), np.eye(3) * 1e-3, sp, compressed=compressed)
    f.add_landmarks(np.column_stack([rng.uniform(5, 25, 12), rng.uniform(0.1, 3.0, 12)]))
    return f


def test_batched_prediction_equals_sequential_ekf():
    rng = np.random.default_rng(8)
    sp = SlamParams(q_pose=(0.01, 0.02, 1e-4))
    f = _mapped_filter(False, rng, sp)
    x, P = f.x.copy(), f.P.copy()
    for _ in range(40):  # many inputs between two scans, nothing applied to P until it is read
        u = np.array([rng.uniform(0, 5), rng.uniform(-0.4, 0.4)])
        dt = rng.uniform(0.01, 0.05)
        f.predict(u, dt)
        x, P = _reference_predict(x, P, u, dt, sp)
    assert f._pending
    np.testing.assert_allclose(f.pose, x[:3], atol=1e-12)
    np.testing.assert_allclose(f.P, P, atol=1e-12, rtol=1e-10)
    np.testing.assert_allclose(f.x, x, atol=1e-12)


def test_batched_prediction_accumulates_phi_in_compressed_mode():
    rng = np.random.default_rng(9)
    sp = SlamParams(max_range=30, local_radius=50, local_exit=15)
    lm = rng.uniform(-100, 100, (100, 2))
    e = CekfSlam(np.zeros(3), np.eye(3) * 1e-4, sp, compressed=False)
    c = CekfSlam(np.zeros(3), np.eye(3) * 1e-4, sp, compressed=True)
    for f in (e, c):
        f.add_landmarks(observe(np.zeros(3), lm))
        f.global_update()
    assert c.track and c.b_idx.size > 0
    pose = np.zeros(3)
    for k in range(100):
        u = np.array([3.0, 0.2 * np.sin(k / 15)])
        for _ in range(8):  # 8 inputs per scan
            pose = vehicle_step(pose, u, 0.025)
            um = u + rng.normal(0, [0.3, 0.02])
            e.predict(um, 0.025)
            c.predict(um, 0.025)
        zz = observe(pose, lm)
        vis = np.flatnonzero((zz[:, 0] < 30) & (zz[:, 1] >= 0) & (zz[:, 1] <= np.pi))
        z = zz[vis] + rng.normal(0, [0.3, 0.01], (vis.size, 2))
        e.update(z, init_new=False)
        c.update(z, init_new=False)
    xe, Pe = e.mean_cov()
    xc, Pc = c.mean_cov()
    assert c.n_global_updates > 3
    assert np.abs(xe - xc).max() < 1e-9 and np.abs(Pe - Pc).max() < 1e-9


def test_fused_prediction_matches_model_functions():
    from track_core.slam.association import innovation_covariances
    from track_core.slam.models import observe_jacobians

    rng = np.random.default_rng(10)
    f = _mapped_filter(False, rng, SlamParams())
    f.predict(np.array([2.0, 0.1]), 0.5)
    A = rng.normal(size=(f.x.size, f.x.size))
    f.P = f.P + 0.01 * A @ A.T          # generic correlations
    lm, Hv, Hm, zhat, S = f._predicted()
    Hv2, Hm2 = observe_jacobians(f.pose, lm)
    np.testing.assert_allclose(zhat, observe(f.pose, lm), atol=1e-12)
    np.testing.assert_allclose(Hv, Hv2, atol=1e-12)
    np.testing.assert_allclose(Hm, Hm2, atol=1e-12)
    P = f.P
    m = lm.shape[0]
    Pmm = np.array([P[3 + 2 * j:5 + 2 * j, 3 + 2 * j:5 + 2 * j] for j in range(m)])
    Pvm = P[:3, 3:].reshape(3, m, 2).transpose(1, 0, 2)
    np.testing.assert_allclose(S, innovation_covariances(Hv2, Hm2, P[:3, :3], Pvm, Pmm), atol=1e-10)


def test_tentative_landmarks_need_min_obs_scans():
    sp = SlamParams(min_obs=3, tentative_max_gap=2)
    f = CekfSlam(np.zeros(3), np.eye(3) * 1e-6, sp, compressed=False)
    tree = np.array([10.0, 2.0])
    spurious = [np.array([[12.0, 0.4]]), np.array([[7.0, 2.6]]), np.array([[20.0, 1.0]])]
    for k in range(2):
        f.update(np.vstack([observe(np.zeros(3), tree)[None], spurious[k]]))
        assert f.n_landmarks == 0
    assert f.n_tentative == 3                  # the tree (seen twice) + two one-off returns
    f.update(observe(np.zeros(3), tree)[None])
    assert f.n_landmarks == 1                  # third sighting: mapped
    np.testing.assert_allclose(f.landmarks()[0], tree, atol=1e-9)
    for _ in range(3):
        f.update(np.zeros((0, 2)))
    assert f.n_tentative == 0                  # the one-off returns expired
    assert f.n_landmarks == 1


def test_observations_beyond_max_range_are_ignored():
    sp = SlamParams(max_range=30.0, init_max_range=30.0)
    f = CekfSlam(np.zeros(3), np.eye(3) * 1e-6, sp, compressed=False)
    a = f.update(np.array([[50.0, 1.5], [10.0, 1.5]]))
    assert list(a.new) == [1] and f.n_landmarks == 1
    f.add_landmarks(np.array([[50.0, 1.0]]))   # a mapped far landmark is not associated either
    a = f.update(np.array([[50.0, 1.0]]))
    assert a.obs.size == 0 and a.new.size == 0


def test_risk_fraction_rule():
    R = np.diag([0.01, 1e-4])
    lm = np.array([[0.0, 10.0], [5.0, 10.0], [20.0, 10.0], [40.0, 10.0]])
    zhat = observe(np.zeros(3), lm)
    S = np.tile(np.eye(2) * 1e-6, (4, 1, 1))
    S[0] = np.diag([4.0, 1e-6])                # one landmark (5 m from its neighbour) uncertain by 2 m
    z = zhat[:1]
    assert associate(z, zhat, S, R, lm, risk_fraction=0.0).risk
    assert not associate(z, zhat, S, R, lm, risk_fraction=0.5).risk
    S[:] = np.diag([100.0, 0.04])              # the vehicle is lost: every landmark at risk
    assert associate(z, zhat, S, R, lm, risk_fraction=0.5).risk
    with pytest.raises(ValueError, match='risk_fraction'):
        SlamParams(risk_fraction=1.5)


def test_map_estimate_equals_global_update_without_touching_the_filter():
    import copy

    rng = np.random.default_rng(12)
    lm = rng.uniform(-120, 120, (150, 2))
    sp = SlamParams(max_range=30, local_radius=50, local_exit=15)
    c = CekfSlam(np.zeros(3), np.eye(3) * 1e-4, sp, compressed=True)
    pose = np.zeros(3)
    checked = 0
    for k in range(300):
        u = np.array([3.0, 0.1 * np.sin(k / 40)])
        pose = vehicle_step(pose, u, 0.1)
        c.predict(u + rng.normal(0, [0.3, 0.02]), 0.1)
        zz = observe(pose, lm)
        vis = np.flatnonzero((zz[:, 0] < 30) & (zz[:, 1] >= 0) & (zz[:, 1] <= np.pi))
        c.update(zz[vis] + rng.normal(0, [0.3, 0.01], (vis.size, 2)))
        if k % 20 == 7 and c.track and c.b_idx.size:
            n_glob = c.n_global_updates
            m, C = c.map_estimate()
            assert c.n_global_updates == n_glob
            x, P = copy.deepcopy(c).mean_cov()
            L = (x.size - 3) // 2
            idx = 3 + 2 * np.arange(L)
            r2 = idx[:, None, None] + np.arange(2)[None, :, None]
            blocks = P[r2, np.swapaxes(r2, 1, 2)]
            np.testing.assert_allclose(m, x[3:].reshape(-1, 2), atol=1e-9)
            np.testing.assert_allclose(C, blocks, atol=1e-9)
            checked += 1
    assert checked >= 3


def test_fuse_is_the_kalman_update_for_a_linear_observation():
    rng = np.random.default_rng(13)
    f = _mapped_filter(False, rng, SlamParams())
    f.predict(np.array([2.0, 0.1]), 0.5)
    x0, P0 = f.mean_cov()
    cols = np.array([0, 1, 5, 6])
    H = rng.normal(size=(2, 4))
    R = np.diag([0.3, 0.2])
    z = H @ x0[cols] + np.array([0.5, -0.4])
    f.fuse(lambda xs: (H @ xs, H), cols, z, R, iterations=3)
    Hf = np.zeros((2, x0.size))
    Hf[:, cols] = H
    K = P0 @ Hf.T @ np.linalg.inv(Hf @ P0 @ Hf.T + R)
    x, P = f.mean_cov()
    np.testing.assert_allclose(x, x0 + K @ (z - Hf @ x0), atol=1e-10)
    np.testing.assert_allclose(P, P0 - K @ Hf @ P0, atol=1e-10)


@pytest.mark.parametrize('min_obs', [1, 3])
@pytest.mark.parametrize('compressed', [False, True])
def test_association_log_names_the_landmark_of_every_fused_observation(min_obs, compressed):
    """``association_log``: each update's fused observations with their landmark numbers (creation order),
    then the observations that started landmarks; the numbers survive global updates and repartitions."""
    rng = np.random.default_rng(4)
    lm = np.array([[10.0, 5.0], [20.0, -6.0], [15.0, 12.0], [60.0, 3.0], [70.0, -4.0]])
    f = CekfSlam(np.zeros(3), np.eye(3) * 1e-6, SlamParams(min_obs=min_obs, local_radius=50.0, local_exit=20.0,
                                                            max_range=30.0, init_max_range=30.0),
                 compressed=compressed)
    f.association_log = log = []
    number = {}                                     # true landmark → the filter's number
    pose = np.zeros(3)
    for k in range(60):
        pose = vehicle_step(pose, np.array([2.0, 0.0]), 0.5)
        f.predict(np.array([2.0, 0.0]), 0.5)
        z = observe(pose, lm)
        vis = np.flatnonzero((z[:, 0] < 30.0) & (z[:, 1] >= 0) & (z[:, 1] <= np.pi))
        vis = rng.permutation(vis)                   # scan rows in any order
        z = z[vis] + rng.normal(0.0, [0.05, 0.002], (vis.size, 2))
        if k == 30:
            f.mean_cov()                             # a global update in the middle
        f.update(z)
        a = log[-1]
        assert a.scan == f.n_scans == k + 1
        row = {tuple(r): i for r, i in zip(np.round(z, 9), vis, strict=True)}
        for zz, j in zip(a.z_new, a.new, strict=True):
            number[row[tuple(np.round(zz, 9))]] = int(j)
        for zz, j in zip(a.z, a.landmarks, strict=True):
            assert number[row[tuple(np.round(zz, 9))]] == j
    assert sorted(number.values()) == list(range(f.n_landmarks)) and f.n_landmarks == len(lm)
    fused = sum(a.z.shape[0] for a in log)
    assert fused + sum(a.z_new.shape[0] for a in log) > 60
