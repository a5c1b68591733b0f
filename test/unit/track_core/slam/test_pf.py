import numpy as np
import pytest

from track_core.slam.models import VehicleParams, observe
from track_core.slam.pf import (
    ParticleLocaliser,
    PFParams,
    block_diag_dense,
    decorrelate_blocks,
    helix_particles,
    log_likelihood,
    rereference,
    to_global,
)


def _num_jac(f, x, eps=1e-6):
    x = np.asarray(x, float)
    f0 = f(x)
    J = np.zeros((f0.size, x.size))
    for i in range(x.size):
        d = np.zeros_like(x)
        d[i] = eps
        J[:, i] = (f(x + d) - f(x - d)) / (2 * eps)
    return J


def _flat(pose, lm, base):
    pl, ll, _, _ = rereference(pose, lm, np.eye(3 + lm.size), base)
    return np.concatenate([pl, ll.ravel()])


def test_rereference_jacobian_and_roundtrip():
    rng = np.random.default_rng(0)
    pose = np.array([3.0, -2.0, 0.4])
    lm = rng.uniform(-20, 20, (5, 2))
    base = (1, 3)
    _, _, _, J = rereference(pose, lm, np.eye(13), base)
    Jn = _num_jac(lambda v: _flat(v[:3], v[3:].reshape(-1, 2), base), np.concatenate([pose, lm.ravel()]))
    np.testing.assert_allclose(J, Jn, atol=1e-6)
    pl, ll, _, _ = rereference(pose, lm, np.eye(13), base)
    np.testing.assert_allclose(ll[1], [0, 0], atol=1e-12)
    assert abs(ll[3, 1]) < 1e-12
    back, Gb, Gl = to_global(pl, lm[1], lm[3])
    np.testing.assert_allclose(back, pose, atol=1e-12)
    # observations are frame invariant
    np.testing.assert_allclose(observe(pl, ll), observe(pose, lm), atol=1e-12)
    Gn = _num_jac(lambda v: to_global(v[4:], v[:2], v[2:4])[0], np.concatenate([lm[1], lm[3], pl]))
    np.testing.assert_allclose(np.hstack([Gb, Gl]), Gn, atol=1e-6)


def test_from_base_frame_inverts_base_frame_pose_for_a_batch():
    from track_core.slam.pf import base_frame_pose, from_base_frame

    rng = np.random.default_rng(5)
    b1, b2 = np.array([4.0, -1.0]), np.array([-3.0, 6.0])
    poses = np.column_stack([rng.uniform(-30, 30, (20, 2)), rng.uniform(-np.pi, np.pi, 20)])
    local = np.array([base_frame_pose(p, b1, b2)[0] for p in poses])
    back = from_base_frame(local, b1, b2)
    np.testing.assert_allclose(back[:, :2], poses[:, :2], atol=1e-12)
    np.testing.assert_allclose(np.cos(back[:, 2] - poses[:, 2]), 1.0, atol=1e-12)
    # to_global's pose is the same transform
    np.testing.assert_array_equal(to_global(local[3], b1, b2)[0], back[3])


def test_decorrelation_bound_is_conservative():
    rng = np.random.default_rng(1)
    for c in (2, 5, 12):
        A = rng.normal(size=(2 * c, 2 * c + 3))
        P = A @ A.T
        Pt = block_diag_dense(decorrelate_blocks(P))
        assert np.min(np.linalg.eigvalsh(Pt - P)) > -1e-9 * np.abs(P).max()
        k = np.exp(rng.normal(size=(c, c)))
        k = np.triu(k) + np.tril(1 / k.T, -1)
        np.fill_diagonal(k, 1.0)
        Pt = block_diag_dense(decorrelate_blocks(P, k))
        assert np.min(np.linalg.eigvalsh(Pt - P)) > -1e-9 * np.abs(P).max()
    # an element-wise |C| would fail this check on some matrices; the polar form must not
    with pytest.raises(ValueError, match='k'):
        decorrelate_blocks(P, -np.ones((12, 12)))


def test_helix_samples_lie_on_helix():
    rng = np.random.default_rng(2)
    pose = np.array([1.0, 2.0, 0.3])
    lm = np.array([[10.0, 5.0], [4.0, 12.0]])
    z = observe(pose, lm)
    p = PFParams(sigma_r=1e-9, sigma_b=1e-9, n_particles=500)
    parts = helix_particles(z, lm, np.zeros((2, 2)), pose, np.diag([25.0, 25.0, 0.01]), 500, rng, p)
    # every particle sees one of the landmarks exactly as observed by one of the observations
    zz = observe(parts[:, None, :], lm[None])
    err = np.abs(zz[:, None, :, :] - z[None, :, None, :]).sum(-1).min(axis=(1, 2))
    assert np.all(err < 1e-4)
    # near-truth particles exist
    assert np.min(np.linalg.norm(parts[:, :2] - pose[:2], axis=1)) < 0.5


def test_pf_converges_on_true_pose():
    rng = np.random.default_rng(3)
    lm = np.stack(np.meshgrid(np.arange(0, 40, 8.0), [-8.0, 8.0, 16.0]), -1).reshape(-1, 2)
    lm = lm + rng.uniform(-2.5, 2.5, lm.shape)  # irregular, like trees (a regular grid is shift-ambiguous)
    pose = np.array([12.0, 0.5, 0.1])
    z = observe(pose, lm)
    z = z[(z[:, 0] < 30) & (z[:, 1] > 0) & (z[:, 1] < np.pi)]
    params = PFParams(sigma_r=0.2, sigma_b=np.deg2rad(0.5))
    z = z + rng.normal(size=z.shape) * [0.2, np.deg2rad(0.5)]
    pf = ParticleLocaliser(lm, np.tile(0.01 * np.eye(2), (len(lm), 1, 1)), params, VehicleParams(), rng)
    pf.initialise(z, pose + np.array([6.0, -5.0, 0.02]), np.diag([64.0, 64.0, 0.003]))
    pf.update(z)
    mean, _ = pf._last
    assert np.linalg.norm(mean[:2] - pose[:2]) < 1.0
    assert np.isfinite(log_likelihood(pf.particles, z, lm, pf.lm_cov, params)).all()


def test_map_plane_likelihood_matches_measurement_space_reference():
    from track_core.slam.pf import log_likelihood_dense

    rng = np.random.default_rng(4)
    lm = rng.uniform(-30, 30, (60, 2))
    cov = np.array([np.diag(rng.uniform(0.02, 0.3, 2)) for _ in range(60)])
    pose = np.array([1.0, 2.0, 0.3])
    z = observe(pose, lm)
    z = z[(z[:, 0] < 25) & (z[:, 1] > 0) & (z[:, 1] < np.pi)]
    params = PFParams(sigma_r=0.3, sigma_b=0.01)
    z = z + rng.normal(size=z.shape) * [0.3, 0.01]
    parts = pose + rng.normal(size=(1500, 3)) * [1.5, 1.5, 0.03]
    a = log_likelihood(parts, z, lm, cov, params)
    b = log_likelihood_dense(parts, z, lm, cov, params)
    assert np.corrcoef(a, b)[0, 1] > 0.999
    # the particles each form would keep agree
    top_a, top_b = set(np.argsort(a)[-50:]), set(np.argsort(b)[-50:])
    assert len(top_a & top_b) >= 40
    # no landmark near any observation point: clutter only
    far = log_likelihood(parts[:3] + np.array([500.0, 0.0, 0.0]), z, lm, cov, params)
    np.testing.assert_allclose(far, z.shape[0] * np.log(params.clutter))


def test_base_frame_pose_jacobians_and_inverse():
    from track_core.slam.pf import base_frame_pose

    rng = np.random.default_rng(6)
    for _ in range(5):
        pose = np.array([*rng.normal(size=2) * 10, rng.uniform(-3, 3)])
        b1, b2 = rng.normal(size=2) * 10, rng.normal(size=2) * 10
        pl, Jv, Jb = base_frame_pose(pose, b1, b2)
        back, _, _ = to_global(pl, b1, b2)
        np.testing.assert_allclose(back[:2], pose[:2], atol=1e-10)
        assert abs(np.angle(np.exp(1j * (back[2] - pose[2])))) < 1e-10
        Jn = _num_jac(lambda v, b1=b1, b2=b2: base_frame_pose(v, b1, b2)[0], pose)
        np.testing.assert_allclose(Jv, Jn, atol=1e-6)
        Jn = _num_jac(lambda v, pose=pose: base_frame_pose(pose, v[:2], v[2:])[0], np.concatenate([b1, b2]))
        np.testing.assert_allclose(Jb, Jn, atol=1e-6)
