"""Issue 14: the batch least-squares baseline, the filter's reader noise and Gaussian weights, the
bimodal tag estimate, the guidance with an LLRP reader, and the rfid-reader experiment."""

import math
from dataclasses import replace

import numpy as np
import pytest

from track_core.rfid.batch import fit_tag, path_from_moves, tag_in_user_frame
from track_core.rfid.pf import PFParams, RfidParticleFilter
from track_core.rfid.phase import PhaseModel
from track_core.rfid.search import run_search
from track_core.rfid.signal import UnwrapConfig
from track_core.rfid.world import WorldParams

PM = PhaseModel()


def _dphi(positions, tag, k):
    r = np.hypot(*(positions - tag).T)
    return k * np.diff(r)


def test_batch_fit_recovers_the_tag_from_noiseless_dphi_on_a_turning_path():
    pos, head = path_from_moves(np.full(6, 0.5), np.array([0.0, 0.0, 0.6, 0.0, -0.9, 0.0]))
    assert pos.shape == (7, 2) and head[-1] == pytest.approx(-0.3)
    tag = np.array([2.3, 1.7])
    fit = fit_tag(pos, _dphi(pos, tag, PM.k), PM.k)
    assert np.allclose(fit.xy, tag, atol=1e-6) and fit.cost < 1e-10 and not fit.ambiguous


def test_batch_fit_on_a_straight_path_reports_the_mirror():
    pos, _ = path_from_moves(np.full(5, 0.2), np.zeros(5))
    tag = np.array([0.6, -1.1])
    fit = fit_tag(pos, _dphi(pos, tag, PM.k), PM.k)
    assert fit.ambiguous
    assert min(np.hypot(*(fit.xy - tag)), np.hypot(*(fit.mirror - tag))) < 1e-6
    assert np.allclose(fit.mirror, fit.xy * [1.0, -1.0], atol=1e-9)     # the walking line is y = 0
    u = tag_in_user_frame(np.array([1.0, 1.0]), np.array([1.0, 0.0]), math.pi / 2)
    assert np.allclose(u, [1.0, 0.0])                                     # 1 m ahead of a user facing +y


def _still_pf(weighting: str, n: int = 400) -> RfidParticleFilter:
    """A filter without motion noise or jitter, so that the weights of one update can be checked by hand."""
    p = PFParams(n_particles=n, s_r=0.0, s_a=0.0, jitter_std=0.0, weighting=weighting, reinit_factor=None,
                 resample_fraction=1e-9)
    pf = RfidParticleFilter(p, PM, np.random.default_rng(0))
    pf.initialize()
    return pf


@pytest.mark.parametrize('weighting', ['gaussian', 'inverse_square'])
def test_weights_follow_the_chosen_likelihood_with_the_readers_dphi_std(weighting):
    pf = _still_pf(weighting)
    x, y, a = pf.particles.T.copy()
    x1, y1 = x + 0.5 * np.cos(a), y + 0.5 * np.sin(a)
    dphi, sd = -12.0, 0.7
    m = PM.k * (np.hypot(x1, y1) - np.hypot(x, y)) - dphi
    pf.update(dphi, 0.0, dphi_std=sd)
    m0 = PM.dphi_noise_std(0.0, sd)            # eq. 11 with s_r = 0: the reader's std alone
    assert m0 == pytest.approx(sd)
    want = np.exp(-0.5 * (m / m0) ** 2) if weighting == 'gaussian' else 1.0 / np.maximum(m * m, m0 * m0)
    assert np.allclose(pf.weights, want / want.sum(), rtol=1e-9, atol=1e-300)


def test_no_dphi_std_keeps_the_papers_floor():
    p = PFParams()
    assert p.floor(PM) == pytest.approx(PM.dphi_noise_std(p.s_r))
    assert p.floor(PM, 0.01) < p.floor(PM)
    with pytest.raises(ValueError, match='weighting'):
        PFParams(weighting='cauchy')


def _cloud(ys, n=2000, rng=None):
    """Particles facing +x at distance 2 m ahead of the tag... placed so the tag is at (2, y) in their frame."""
    rng = rng or np.random.default_rng(1)
    y = np.concatenate([np.full(k, yy) for yy, k in ys]) + rng.normal(0, 0.05, sum(k for _, k in ys))
    x = 2.0 + rng.normal(0, 0.05, y.size)
    # a user at (−x, −y) facing +x sees the tag at the origin at (x, y) in their own frame
    return np.column_stack([-x, -y, np.zeros(y.size)])


def test_tag_posterior_reports_two_mirror_modes_and_takes_the_heavier():
    pf = RfidParticleFilter(PFParams(n_particles=2000), PM, np.random.default_rng(0))
    pf.particles = _cloud([(0.8, 1300), (-0.8, 700)])
    pf.weights = np.full(2000, 1 / 2000)
    est = pf.tag_posterior()
    assert est.bimodal and est.side_weight == pytest.approx(0.65)
    assert est.x == pytest.approx(2.0, abs=0.02) and est.y == pytest.approx(0.8, abs=0.02)   # not the 0.24 mean
    assert est.bearing == pytest.approx(math.atan2(0.8, 2.0), abs=0.02)
    pf.particles = _cloud([(0.8, 1950), (-0.8, 50)])          # the mirror side has < 10 %: one mode
    assert not pf.tag_posterior().bimodal
    pf.particles = _cloud([(0.0, 2000)])                        # straight ahead: one mode across the line
    est = pf.tag_posterior()
    assert not est.bimodal and abs(est.y) < 0.01


def test_guidance_with_an_llrp_reader_finds_the_tag_like_the_papers():
    seeds = np.random.SeedSequence(11).spawn(6)
    pf = PFParams(n_particles=100)
    paper = WorldParams()
    llrp = replace(paper, phase=replace(paper.phase, convention='llrp'))
    a = [run_search(paper, pf, np.random.default_rng(s)) for s in seeds]
    b = [run_search(llrp, pf, np.random.default_rng(s)) for s in seeds]
    assert all(o.success for o in a) and all(o.success for o in b)   # the rates over 200 runs: README
    as_is = [run_search(llrp, pf, np.random.default_rng(s), max_steps=40, unwrap=UnwrapConfig.for_model(paper.phase))
             for s in seeds[:2]]
    assert not any(o.success for o in as_is)
