import math
from dataclasses import replace

import numpy as np
import pytest

from track_core.rfid.pf import (
    PFParams,
    RfidParticleFilter,
    guarded_inverse_square,
    initial_particles,
    loop_update,
    suggested_turn,
)
from track_core.rfid.phase import PhaseModel


def test_initial_particles_one_quadrant_tag_in_beam():
    p = PFParams(n_particles=5000, beam_width=math.radians(68))
    P = initial_particles(p.n_particles, p, np.random.default_rng(0))
    assert np.all(P[:, 0] <= 0) and np.all(P[:, 1] <= 0)
    r = np.hypot(P[:, 0], P[:, 1])
    assert r.min() >= p.init_range[0] and r.max() <= p.init_range[1]
    rel = np.angle(np.exp(1j * (np.arctan2(-P[:, 1], -P[:, 0]) - P[:, 2])))
    assert np.all(np.abs(rel) <= math.radians(34) + 1e-12)
    assert rel.min() < -math.radians(30) and rel.max() > math.radians(30)   # both sides of the heading


def test_guarded_inverse_square():
    m0 = 2.0
    m = np.array([0.0, 1e-9, 1.0, 2.0, 3.0, -10.0])
    f = guarded_inverse_square(m, m0)
    assert np.all(np.isfinite(f))
    np.testing.assert_allclose(f[:4], 1 / m0**2)             # bounded as m → 0
    np.testing.assert_allclose(f[4:], 1 / m[4:] ** 2)        # the paper's 1/m² beyond the floor


def test_default_floor_is_eq11_std():
    pm = PhaseModel()
    assert PFParams().floor(pm) == pytest.approx(pm.dphi_noise_std(0.1))
    assert PFParams(weight_floor=0.5).floor(pm) == 0.5


def _particle(bearing_to_tag, heading):
    """A particle 5 m from the tag, which it sees at ``bearing_to_tag`` relative to ``heading``."""
    pos = -5.0 * np.array([math.cos(heading + bearing_to_tag), math.sin(heading + bearing_to_tag)])
    return [pos[0], pos[1], heading]


def test_circular_suggestion_does_not_break_at_pi():
    P = np.array([_particle(math.radians(179), 0.3), _particle(math.radians(-179), 0.3)])
    a = suggested_turn(P, np.array([0.5, 0.5]), 'mean')
    assert abs(abs(a) - math.pi) < 1e-9                         # "turn around", not 0 ("go straight")
    raw = 0.5 * math.radians(179) + 0.5 * math.radians(-179)   # the printed eq. 24
    assert abs(raw) < 1e-9


def test_side_rule_picks_the_heavier_mirror_mode():
    P = np.array([_particle(math.radians(40), 1.0), _particle(math.radians(-40), 1.0),
                  _particle(math.radians(45), 1.0)])
    w = np.array([0.3, 0.4, 0.3])                               # left side 0.6, right 0.4
    assert abs(suggested_turn(P, w, 'mean')) < math.radians(15)   # between the modes
    assert suggested_turn(P, w, 'side') == pytest.approx(math.radians(42.5), abs=1e-9)
    assert suggested_turn(P, w, 'auto') == pytest.approx(math.radians(42.5), abs=1e-9)   # R̄ < 0.9
    tight = np.array([_particle(math.radians(b), 1.0) for b in (-3.0, 2.0, 4.0)])
    assert suggested_turn(tight, np.full(3, 1 / 3), 'auto') == pytest.approx(
        suggested_turn(tight, np.full(3, 1 / 3), 'mean'))                              # unimodal: eq. 24


def test_motion_sums_turns_eq19_20_without_noise():
    p = PFParams(n_particles=3, s_r=0.0, s_a=0.0, jitter_std=0.0, reinit_factor=None)
    pf = RfidParticleFilter(p, PhaseModel(), np.random.default_rng(0))
    pf.initialize()
    P0 = pf.particles.copy()
    turns = [0.2, -0.5, 0.1]                                    # J = 3 turns since the last move
    pf.update(-10.0, sum(turns))
    a = P0[:, 2] + sum(turns)
    exp = P0[:, :2] + 0.5 * np.column_stack([np.cos(a), np.sin(a)])
    order = np.lexsort(pf.particles.T[::-1])
    sel = np.array([np.argmin(np.hypot(*(exp - q[:2]).T)) for q in pf.particles])   # resampling may duplicate
    np.testing.assert_allclose(pf.particles[:, :2], exp[sel], atol=1e-12)
    assert order.size == 3


def test_vectorised_update_equals_the_per_particle_loop():
    p = PFParams(n_particles=200, suggestion='mean', reinit_factor=None)
    pm = PhaseModel()
    pf = RfidParticleFilter(p, pm, np.random.default_rng(1))
    pf.update(-15.0, 0.0)
    for dphi, turn in [(-12.0, 0.4), (3.0, -2.0)]:
        P, w = pf.particles.tolist(), pf.weights.tolist()
        probe = np.random.default_rng()
        probe.bit_generator.state = pf.rng.bit_generator.state
        noise = probe.standard_normal((4, p.n_particles)).T
        u = probe.random()
        info = pf.update(dphi, turn, force_resample=True)
        P2, w2, a2 = loop_update(P, w, dphi, turn, p, pm, np.random.default_rng(), noise=noise, resample_u=u,
                                 resampling='systematic')
        np.testing.assert_allclose(pf.particles[:, :2], np.array(P2)[:, :2], atol=1e-9)
        np.testing.assert_allclose(np.angle(np.exp(1j * (pf.particles[:, 2] - np.array(P2)[:, 2]))), 0, atol=1e-9)
        np.testing.assert_allclose(pf.weights, w2)
        assert info.suggested_turn == pytest.approx(a2, abs=1e-9)


def test_loop_multinomial_runs():
    p = PFParams(n_particles=50)
    pm = PhaseModel()
    rng = np.random.default_rng(2)
    P = initial_particles(50, p, rng).tolist()
    P2, w2, a = loop_update(P, [1 / 50] * 50, -12.0, 0.1, p, pm, rng, first=True)
    assert len(P2) == 50 and sum(w2) == pytest.approx(1.0) and -math.pi <= a <= math.pi


def test_resampling_only_below_two_thirds_n():
    pm = PhaseModel()
    pf = RfidParticleFilter(PFParams(n_particles=500, reinit_factor=None), pm, np.random.default_rng(3))
    info = pf.update(-18.0, 0.0)                 # informative first step: weights spread → resample
    assert info.ess < 2 / 3 * 500 and info.resampled
    assert np.allclose(pf.weights, 1 / 500)
    # a floor so large that every particle gets the same weight keeps the ESS at N: no resampling
    flat = RfidParticleFilter(PFParams(n_particles=500, weight_floor=1e6), pm, np.random.default_rng(3))
    info = flat.update(-18.0, 0.0)
    assert info.ess == pytest.approx(500) and not info.resampled


def test_bad_input_leaves_the_state_unchanged():
    pf = RfidParticleFilter(PFParams(n_particles=100), PhaseModel(), np.random.default_rng(4))
    pf.update(-15.0, 0.0)
    before = pf.snapshot()
    for dphi, turn in [(math.nan, 0.0), (math.inf, 0.0), (-10.0, math.nan)]:
        with pytest.raises(ValueError, match='finite'):
            pf.update(dphi, turn)
    after = pf.snapshot()
    np.testing.assert_array_equal(before[0], after[0])
    np.testing.assert_array_equal(before[1], after[1])
    assert before[2:5] == after[2:5] and before[5] == after[5]


def test_lost_cloud_is_reinitialised():
    p = PFParams(n_particles=50)
    pf = RfidParticleFilter(p, PhaseModel(), np.random.default_rng(5))
    pf.update(-18.0, 0.0)
    pf.particles = np.tile([[-5.0, -5.0, math.pi / 4]], (50, 1))   # all walking straight at the tag ...
    pf.update(18.0, 0.0)                                           # ... but the user walked straight away
    assert pf.last_reinit and pf.n_reinits == 1
    assert np.ptp(pf.particles[:, 0]) > 1.0
    off = RfidParticleFilter(replace(p, reinit_factor=None), PhaseModel(), np.random.default_rng(5))
    off.update(-18.0, 0.0)
    off.particles = np.tile([[-5.0, -5.0, math.pi / 4]], (50, 1))
    off.update(18.0, 0.0)
    assert not off.last_reinit


@pytest.mark.parametrize('kw', [{'n_particles': 0}, {'init_range': (2.0, 1.0)}, {'suggestion': 'mode'},
                                {'resample_fraction': 0.0}, {'beam_width': 0.0}, {'reinit_factor': -1.0}])
def test_bad_params(kw):
    with pytest.raises(ValueError):
        PFParams(**kw)


def test_estimate_nan_before_first_update_then_finite():
    pf = RfidParticleFilter(PFParams(), PhaseModel(), np.random.default_rng(6))
    assert all(math.isnan(v) for v in pf.tag_estimate())
    assert pf.suggested_turn() == 0.0
    pf.update(-18.0, 0.0)
    d, b = pf.tag_estimate()
    assert 0 < d < 16 and -math.pi <= b <= math.pi


def _first_step_misfit(params: PFParams, dphi: float, seed: int) -> float:
    """Median |predicted dφ − dφ| of the particles right after the first update (no jitter at the first)."""
    pm = PhaseModel()
    pf = RfidParticleFilter(params, pm, np.random.default_rng(seed))
    pf.update(dphi, 0.0)
    x, y, a = pf.particles.T
    x0, y0 = x - 0.5 * np.cos(a), y - 0.5 * np.sin(a)          # the step's start, up to the step noise
    return float(np.median(np.abs(pm.k * (np.hypot(x, y) - np.hypot(x0, y0)) - dphi)))


def test_init_boost_keeps_n_particles_that_fit_the_first_step():
    base = PFParams(n_particles=10, s_r=0.0, s_a=0.0)
    boosted = replace(base, init_boost=100)
    plain = [_first_step_misfit(base, -8.0, s) for s in range(20)]
    boost = [_first_step_misfit(boosted, -8.0, s) for s in range(20)]
    assert np.median(boost) < 0.5 * np.median(plain)
    pf = RfidParticleFilter(boosted, PhaseModel(), np.random.default_rng(0))
    pf.update(-8.0, 0.0)
    assert pf.particles.shape == (10, 3) and np.allclose(pf.weights, 0.1)
    with pytest.raises(ValueError, match='init_boost'):
        PFParams(init_boost=0)


def test_student_t_weights_have_heavier_tails_than_gaussian():
    pm = PhaseModel()
    m = np.array([0.0, 1.0, 10.0])
    lt = RfidParticleFilter(PFParams(weighting='student_t', t_dof=4.0), pm, np.random.default_rng(0))._log_fw(m, 1.0)
    lg = RfidParticleFilter(PFParams(weighting='gaussian'), pm, np.random.default_rng(0))._log_fw(m, 1.0)
    assert lt[0] == lg[0] == 0.0
    assert lt[2] - lt[0] > lg[2] - lg[0] + 40.0                  # 10 m₀ off: ≈ −9.7 against −50
    pf = RfidParticleFilter(PFParams(n_particles=200, weighting='student_t'), pm, np.random.default_rng(1))
    pf.update(-12.0, 0.0)
    pf.update(-11.0, 0.3)
    assert np.isfinite(pf.weights).all() and pf.weights.sum() == pytest.approx(1.0)
    with pytest.raises(ValueError, match='t_dof'):
        PFParams(t_dof=0.0)


def test_predict_moves_the_particles_without_weighting_them():
    """An unusable MOVE: the particles follow the commanded step, the weights stay."""
    pf = RfidParticleFilter(PFParams(n_particles=500, s_r=0.0, s_a=0.0, jitter_std=0.0), PhaseModel(),
                            np.random.default_rng(0))
    pf.update(-5.0, 0.0)
    w, before = pf.weights.copy(), pf.particles.copy()
    pf.predict(math.pi / 2)
    after = pf.particles
    assert np.array_equal(pf.weights, w)
    step = after[:, :2] - before[:, :2]
    assert np.allclose(np.hypot(step[:, 0], step[:, 1]), 0.5)
    assert np.allclose(np.cos(after[:, 2] - before[:, 2]), 0.0, atol=1e-9)    # turned by π/2
    with pytest.raises(ValueError):
        pf.predict(math.nan)
    fresh = RfidParticleFilter(PFParams(n_particles=50), PhaseModel(), np.random.default_rng(1))
    fresh.predict(0.0)                  # the first MOVE unusable: created at its start, then moved
    assert fresh.initialized and fresh.particles.shape == (50, 3)
