import logging

import numpy as np
import pytest

from track_core.slam.blas import single_threaded_blas
from track_core.slam.cekf import SlamParams
from track_core.slam.hybrid import HybridParams, HybridSlam
from track_core.slam.models import observe
from track_core.slam.pf import PFParams
from track_core.slam.profiles import loop_sim_params
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


def _loop_run_checking_last_particles(sim_seed: int, filter_seed: int):
    """The slam-loop feed (``experiments.run_loop_once``) with ``last_particles`` checked after every scan."""
    w = LoopWorld()
    sp, pp = loop_sim_params(w)
    run = simulate(w, np.random.default_rng(sim_seed))
    h = HybridSlam(w.start(), np.diag([1e-6] * 3), np.random.default_rng(filter_seed), sp, pp,
                   HybridParams(trigger_on_ambiguity=True))
    pf_scans, handover = [], []
    with single_threaded_blas():
        _feed_checking_last_particles(w, run, h, pf_scans, handover)
    return h, pf_scans, handover


def _feed_checking_last_particles(w, run, h, pf_scans, handover) -> None:
    si = 0
    for k in range(len(run.t)):
        h.process_input(run.t[k], *run.u_meas[k])
        while si < len(run.scans) and run.scans[si][0] <= run.t[k] + w.dt + 1e-9:
            ts, z, _ = run.scans[si]
            si += 1
            was_pf, n_ev = h.mode == 'PF', len(h.events)
            used = h.n_cekf_scans + h.n_pf_scans
            h.process_scan(ts, z)
            assert h.n_cekf_scans + h.n_pf_scans > used, f'scan at {ts:.2f} s used by neither filter'
            step = h.last_particles
            new = [e.kind for e in h.events[n_ev:]]
            ran = was_pf or 'to_pf' in new   # the PF was updated with this scan
            assert (step is not None and step.scan == h.n_scans) == ran
            if not ran:
                continue
            assert step.t == ts and step.particles.shape == (h.pf_params.n_particles, 3)
            pf_scans.append(ts)
            if h.mode == 'PF':
                np.testing.assert_array_equal(step.particles, h.particles())
            else:  # the converging scan: the live cloud is gone, the last one is kept
                assert h.particles().shape == (0, 3)
                truth = run.truth[round(ts / w.dt)]
                handover.append((new, float(np.linalg.norm(step.particles[:, :2].mean(0) - truth[:2]))))


def _known_map(seed: int):
    """A filter that knows a map of 16 trunks ~8 m apart ahead of it but whose pose has a 3 m σ: the
    failure detector fires on the next scan (the pose error × separation rule, association.py)."""
    gx, gy = np.meshgrid(np.arange(4.0, 29.0, 8.0), np.arange(-12.0, 13.0, 8.0))
    lm = np.stack([gx.ravel(), gy.ravel()], 1) + np.random.default_rng(99).uniform(-1.5, 1.5, (16, 2))
    h = HybridSlam(np.zeros(3), np.eye(3) * 1e-8, np.random.default_rng(seed),
                   SlamParams(max_range=30.0, init_max_range=30.0, local_radius=60.0, local_exit=20.0),
                   PFParams(n_particles=1000), HybridParams())
    h.process_input(0.0, 0.0, 0.0)
    h.cekf.add_landmarks(observe(np.zeros(3), lm))
    h.cekf.set_vehicle(np.zeros(3), np.diag([9.0, 9.0, np.deg2rad(2.0) ** 2]), np.zeros((3, lm.size)))
    truth = np.array([2.5, -2.0, np.deg2rad(1.5)])
    z = observe(truth, lm)
    vis = np.flatnonzero((z[:, 0] < 30.0) & (z[:, 1] >= 0.0) & (z[:, 1] <= np.pi))
    z = z[vis] + np.random.default_rng(seed).normal(0.0, [0.05, 0.002], (vis.size, 2))
    return h, truth, z


@pytest.mark.parametrize('n_obs', [1, 2])
def test_a_scan_too_poor_for_a_narrow_helix_starts_the_pf_and_is_used(n_obs):
    """The detector fires on a scan of one or two trunks: that scan starts the PF (its helix rings, eqs.
    12-13) instead of being thrown away, and the next, full scan hands back to the CEKF at the truth."""
    h, truth, z = _known_map(0)
    assert h.cekf.associate(z[:n_obs])[0].risk
    assert h.process_scan(0.1, z[np.argsort(z[:, 0])[:n_obs]])
    assert h.mode == 'PF' and [e.kind for e in h.events] == ['to_pf']
    assert (h.n_scans, h.n_pf_scans, h.n_cekf_scans) == (1, 1, 0)
    assert h.process_scan(0.2, z)
    assert [(e.kind, e.scans) for e in h.events] == [('to_pf', 0), ('to_cekf', 2)]
    assert (h.n_scans, h.n_pf_scans, h.n_cekf_scans) == (2, 2, 1)   # the hand-over scan: used by both
    assert np.linalg.norm(h.pose[:2] - truth[:2]) < 0.2


def test_last_particles_keeps_the_cloud_of_a_one_scan_pf_episode():
    h0 = HybridSlam(np.zeros(3), np.eye(3) * 1e-4, np.random.default_rng(0))
    assert h0.last_particles is None
    h, truth, z = _known_map(2)   # a full scan: the PF starts and converges on it
    h.process_scan(0.1, z)
    assert [(e.kind, e.scans) for e in h.events] == [('to_pf', 0), ('to_cekf', 1)]
    step = h.last_particles
    assert step.t == 0.1 and step.scan == h.n_scans == 1 and h.particles().shape == (0, 3)
    assert np.linalg.norm(step.particles[:, :2].mean(0) - truth[:2]) < 0.5   # the converged cloud is at the truth
    h.process_input(0.15, 0.0, 0.0)
    h.process_scan(0.2, z)
    assert h.mode == 'CEKF' and h.last_particles is step and step.scan < h.n_scans   # kept, stamped with its scan
    with pytest.raises(ValueError):
        step.particles[0, 0] = 0.0   # read-only


def test_last_particles_follows_every_scan_of_a_longer_pf_episode():
    # the slam_sim scenario's seeds (config/slam_sim.yaml)
    h, pf_scans, handover = _loop_run_checking_last_particles(1, 2)
    episodes = [e.scans for e in h.events if e.kind in ('to_cekf', 'pf_timeout')]
    assert episodes == [3] and len(pf_scans) == 3 and handover[0][0] == ['to_cekf']
    assert handover[0][1] < 2.0, handover
    assert h.n_cekf_scans + h.n_pf_scans - 1 == h.n_scans   # every scan used, the hand-over one by both
