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


def _mirror_cloud(sides):
    """Users facing +x with the tag 2 m ahead and ``y`` to the left: [(y, count), ...] → (N, 3) particles."""
    y = np.concatenate([np.full(n, v) for v, n in sides])
    return np.column_stack([np.full(y.size, -2.0), -y, np.zeros(y.size)])


def test_tag_sides_gives_both_mirror_modes_with_their_probabilities():
    from track_core.rfid.pf import TagSides

    pf = RfidParticleFilter(PFParams(n_particles=1000), PhaseModel(), np.random.default_rng(0))
    nan = pf.tag_sides()
    assert isinstance(nan, TagSides) and not nan.unknown and math.isnan(nan.left.x)   # before the first update
    pf.particles = _mirror_cloud([(0.8, 550), (-0.8, 450)])
    pf.weights = np.full(1000, 1e-3)
    s = pf.tag_sides()
    assert s.unknown
    assert (s.left.x, s.left.y, s.left.probability) == pytest.approx((2.0, 0.8, 0.55))
    assert (s.right.x, s.right.y, s.right.probability) == pytest.approx((2.0, -0.8, 0.45))
    line = s.describe()
    assert 'unknown' in line and 'p = 0.55' in line and 'p = 0.45' in line and '\n' not in line
    pf.particles = _mirror_cloud([(0.8, 970), (-0.8, 30)])   # the walk has told them apart
    s = pf.tag_sides()
    assert not s.unknown and s.likelier is s.left and s.right.probability == pytest.approx(0.03)
    assert s.describe().startswith('tag side known: left')


def _walk_past_a_tag(ss, turn_deg: float):
    """5 straight MOVEs of 0.2 m past a tag 0.5-2 m beside the track (hopping LLRP reader), then a TURN and 3
    MOVEs: the tag's two modes after the straight part and after the turn, with the true side's mode."""
    from track_core.rfid.batch import tag_in_user_frame
    from track_core.rfid.protocol import Command, CommandKind
    from track_core.rfid.signal import UnwrapConfig
    from track_core.rfid.world import SimReader, WorldParams

    reader = PhaseModel(carrier_hz=920.625e6, wrap_period=2.0 * math.pi, s_theta=0.015, convention='llrp')
    rw, rp = (np.random.default_rng(s) for s in ss.spawn(2))
    start = np.array([-rw.uniform(0.0, 1.5), -rw.uniform(0.5, 2.0) * rw.choice([-1.0, 1.0]), 0.0])
    world = WorldParams(phase=reader, s_step=0.2, s_r=0.002, s_a=math.radians(0.5), beam_width=2.0 * math.pi,
                        channels_hz=tuple(920.625e6 + 0.5e6 * j for j in range(8)), hop_dwell_s=0.2)
    sim = SimReader(world, rw, start=start, unwrap=UnwrapConfig.real_reader(reader))
    pf = RfidParticleFilter(PFParams(n_particles=2000, s_step=0.2, s_r=0.002, s_a=math.radians(0.5),
                                     weighting='student_t', reinit_factor=None, init_range=(0.3, 5.0),
                                     init_boost=10), reader, rp)
    seq = iter(range(1, 100))

    def move(turn):
        r = sim.execute(Command(CommandKind.MOVE, seq=next(seq))).result
        pf.update(r.dphi, turn, dphi_std=r.dphi_std) if r.ok else pf.predict(turn)

    def sides():
        x, y, a = sim.pose
        tx, ty = tag_in_user_frame(np.zeros(2), np.array([x, y]), a)
        s = pf.tag_sides()
        true = s.left if ty > 0 else s.right
        return s.unknown, true.probability, math.hypot(true.x - tx, true.y - ty)

    for _ in range(5):
        move(0.0)
    straight = sides()
    move(sim.execute(Command(CommandKind.TURN, math.radians(turn_deg), seq=next(seq))).result.turn)
    for _ in range(2):
        move(0.0)
    return straight, sides()


def test_a_straight_walk_leaves_the_side_unknown_and_a_turn_tells_it():
    # 30 walks (fixed seeds): measured 30/30 unknown after the straight part, 29/30 resolved with the true side
    # at p > 0.9 after a 60° turn and 3 MOVEs; the bounds allow 3 walks of 30 (10 %) to differ
    runs = [_walk_past_a_tag(s, 60.0) for s in np.random.SeedSequence(11).spawn(30)]
    straight, turned = np.array([r[0] for r in runs], float), np.array([r[1] for r in runs], float)
    assert straight[:, 0].sum() >= 27                      # said: the side is unknown
    assert np.median(straight[:, 2]) < 0.1                 # one of the two modes is the tag (median 0.03 m)
    assert 0.2 < np.median(straight[:, 1]) < 0.8           # and the true side is no likelier than its mirror
    assert ((turned[:, 0] == 0) & (turned[:, 1] > 0.9)).sum() >= 27   # resolved, to the right side
    assert np.median(turned[:, 2]) < 0.1
