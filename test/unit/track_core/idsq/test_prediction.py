"""Velocity-aware drift prediction (``track_core.idsq.prediction``, beyond the paper) against the paper's diffusion."""

from dataclasses import replace

import numpy as np
import pytest

from track_core.idsq.grid import GridSpec, SparseBelief, diffuse, disk_kernel, estimate, sparsify
from track_core.idsq.handoff import (
    HEADER_BYTES,
    MOTION_BYTES,
    Handoff,
    decode_handoff,
    encode_handoff,
    payload_bytes,
    peek_header,
)
from track_core.idsq.models import TrackerParams
from track_core.idsq.prediction import (
    NO_MOTION,
    Bank,
    Motion,
    bank_velocities,
    bank_velocity,
    predict,
    reweight_bank,
    shifted_disk_kernel,
    update_motion,
)

GRID = GridSpec.for_field(150.0, 250.0, 5.0)
DRIFT = TrackerParams(prediction='drift')


def _blob(cx: float, cy: float, s: float = 6.0, motion: Motion | None = None) -> SparseBelief:
    """A Gaussian-shaped belief centred at (cx, cy), well inside the field."""
    idx = np.arange(GRID.n_cells)
    d = GRID.centers(idx) - [cx, cy]
    return sparsify(GRID, idx, np.exp(-0.5 * (d ** 2).sum(axis=1) / s ** 2)).with_motion(motion)


def test_shifted_kernel_is_the_disk_moved_by_the_offset():
    np.testing.assert_array_equal(shifted_disk_kernel(7.5, [0.0, 0.0], 5.0), disk_kernel(7.5, 5.0))
    k = shifted_disk_kernel(7.5, [3.0, -4.2], 5.0)
    m = k.shape[0] // 2
    c = (np.arange(-m, m + 1) * 5.0)
    assert np.isclose(k.sum(), 1.0) and np.all(k >= 0)
    # centroid = offset to the supersampling (cell/16) accuracy; rows are y
    assert abs((k.sum(axis=0) * c).sum() - 3.0) < 5.0 / 16 and abs((k.sum(axis=1) * c).sum() + 4.2) < 5.0 / 16
    # a whole-cell shift is the centred disk moved by one cell
    k1 = shifted_disk_kernel(7.5, [5.0, 0.0], 5.0)
    d = disk_kernel(7.5, 5.0)
    q = k1.shape[0] // 2 - d.shape[0] // 2
    np.testing.assert_allclose(k1[q:q + d.shape[0], q + 1:q + 1 + d.shape[0]], d, atol=1e-12)


def test_diffusion_default_is_the_papers_disk_bit_for_bit():
    assert TrackerParams().prediction == 'diffusion'
    b = _blob(70.0, 120.0, motion=Motion(np.array([0.0, 7.0]), 5))
    p = TrackerParams()
    want = diffuse(b, p.radius, p.sparsity)
    for got in (predict(b, p), predict(b.with_motion(None), DRIFT), predict(b.with_motion(NO_MOTION), DRIFT)):
        np.testing.assert_array_equal(got.idx, want.idx)
        np.testing.assert_array_equal(got.mass, want.mass)
    assert update_motion(b, b, p) is None  # the paper's tracker carries nothing


def test_drift_moves_the_mean_by_v_dt_and_keeps_the_disk_spread():
    v = np.array([2.0, 7.0])
    b = _blob(70.0, 120.0, motion=Motion(v, 3))
    got, plain = predict(b, DRIFT), diffuse(b, DRIFT.radius, DRIFT.sparsity)
    np.testing.assert_allclose(estimate(got).mean, estimate(b).mean + v * DRIFT.dt, atol=0.15)
    assert abs(estimate(got).spread - estimate(plain).spread) < 0.05 * estimate(plain).spread
    assert got.motion is b.motion
    small = predict(b, replace(DRIFT, drift_speed=5.0))
    assert estimate(small).spread < estimate(got).spread


def test_velocity_average_gate_and_clip():
    p = DRIFT
    a, b = _blob(70.0, 120.0), _blob(71.0, 123.5)  # moved (1, 3.5) m in Δt = 0.5 s
    first = update_motion(a, b, p)
    np.testing.assert_allclose(first.velocity, [2.0, 7.0], atol=0.05)  # first observation taken whole
    assert first.count == 1
    nxt = update_motion(a.with_motion(Motion(np.array([0.0, 5.0]), 4)), b, p)
    np.testing.assert_allclose(nxt.velocity, [0.0, 5.0] + p.drift_gain * (np.array([2.0, 7.0]) - [0.0, 5.0]),
                               atol=0.05)
    assert nxt.count == 5
    wide = _blob(70.0, 120.0, s=40.0)  # spread ≫ drift_gate·(v_max·Δt)²: not observed
    assert update_motion(wide, b, p) == NO_MOTION
    far = _blob(100.0, 120.0)  # 60 m/s > v_max: clipped to v_max
    assert np.isclose(np.hypot(*update_motion(a, far, p).velocity), p.v_max)


def test_handoff_v2_carries_the_motion_and_v1_is_unchanged():
    b = _blob(70.0, 120.0)
    plain = encode_handoff(Handoff.from_belief(3, 1, 2, b))
    assert plain[4] == 1 and len(plain) == payload_bytes(b.size) == HEADER_BYTES + 8 * b.size
    mo = Motion(np.array([1.25, -6.5]), 7)
    data = encode_handoff(Handoff.from_belief(3, 1, 2, b.with_motion(mo)))
    assert data[4] == 2 and len(data) == payload_bytes(b.size, motion=True) == len(plain) + MOTION_BYTES
    assert MOTION_BYTES == 10 and peek_header(data) == (1, 2, 3)
    h = decode_handoff(data)
    np.testing.assert_array_equal(h.belief().motion.velocity, np.float32(mo.velocity))
    assert h.belief().motion.count == 7
    np.testing.assert_array_equal(h.idx, b.idx)
    with pytest.raises(ValueError, match='length'):
        decode_handoff(data[:-1])
    bad = bytearray(data)
    bad[HEADER_BYTES:HEADER_BYTES + 4] = np.float32(np.nan).tobytes()
    with pytest.raises(ValueError, match='motion'):
        decode_handoff(bytes(bad))


def test_bad_prediction_settings_raise():
    for kw in ({'prediction': 'kalman'}, {'drift_gain': 0.0}, {'drift_gate': -1.0}, {'drift_speed': -1.0}):
        with pytest.raises(ValueError):
            TrackerParams(**kw)
    assert DRIFT.drift_speed == DRIFT.v_max


BANK = TrackerParams(prediction='bank')


def test_bank_lattice_and_prediction_keep_mass_and_move_each_hypothesis():
    vel, adj = bank_velocities(5.0, 15.0)
    assert vel.shape == (29, 2) and np.all(np.hypot(*vel.T) <= 15.0 + 1e-9)  # 5 m/s lattice inside |v| ≤ 15
    assert np.all(adj == adj.T) and adj.sum(axis=1).min() >= 1
    b = _blob(70.0, 120.0)
    pred = predict(b, BANK)  # from a plain belief: every hypothesis equally likely
    assert isinstance(pred.motion, Bank) and np.isclose(pred.mass.sum(), 1.0)
    np.testing.assert_allclose(bank_velocity(pred, BANK.v_max), [0.0, 0.0], atol=1e-9)  # symmetric lattice
    # one hypothesis only (no switching): the marginal mean moves by v_j·Δt
    j = int(np.flatnonzero((vel == [0.0, 10.0]).all(axis=1))[0])
    one = Bank(5.0, vel.shape[0], j * GRID.n_cells + b.idx, b.mass)
    got = predict(SparseBelief(GRID, b.idx, b.mass, one), replace(BANK, bank_switch=0.0))
    np.testing.assert_allclose(estimate(got).mean, estimate(b).mean + np.array([0.0, 10.0 * BANK.dt]), atol=0.15)
    np.testing.assert_allclose(bank_velocity(got, BANK.v_max), [0.0, 10.0], atol=1e-9)


def test_bank_switching_is_a_rate_so_a_longer_step_switches_more():
    """``bank_switch`` is given per ``bank_switch_dt`` (0.5 s, the §5.1 step): at Δt = 0.5 s it is used as it is
    (Table 4 unchanged), a 1 s step (the maritime scenario) switches with 1 − 0.9² = 0.19, and the prediction
    moves that much of a single hypothesis' mass to its lattice neighbours."""
    assert BANK.switch_per_step == 0.1
    slow = replace(BANK, dt=1.0)
    assert slow.switch_per_step == pytest.approx(0.19, abs=1e-12)
    assert replace(BANK, dt=0.25).switch_per_step == pytest.approx(1 - np.sqrt(0.9), abs=1e-12)
    assert replace(BANK, dt=1.0, bank_switch=0.0).switch_per_step == 0.0
    with pytest.raises(ValueError, match='bank_switch_dt'):
        TrackerParams(prediction='bank', bank_switch_dt=0.0)
    vel, _ = bank_velocities(5.0, 15.0)
    b = _blob(72.5, 122.5, s=4.0)
    j = int(np.flatnonzero((vel == [0.0, 5.0]).all(axis=1))[0])
    one = SparseBelief(GRID, b.idx, b.mass, Bank(5.0, vel.shape[0], j * GRID.n_cells + b.idx, b.mass))
    for p in (BANK, slow):  # no sparsification: the neighbours' faint tails would be dropped and renormalised
        got = predict(one, replace(p, sparsity=0.0)).motion
        w = np.bincount(got.key // GRID.n_cells, weights=got.mass, minlength=vel.shape[0])
        assert w[j] == pytest.approx(1.0 - p.switch_per_step, abs=1e-9), p.dt


def test_bank_update_weights_hypotheses_by_the_likelihood():
    """Two hypotheses predict different positions; a measurement near one of them makes it dominate."""
    vel, _ = bank_velocities(5.0, 15.0)
    b = _blob(72.5, 122.5, s=2.0)
    ja, jb = (int(np.flatnonzero((vel == v).all(axis=1))[0]) for v in ([0.0, 10.0], [0.0, -10.0]))
    key = np.concatenate([ja * GRID.n_cells + b.idx, jb * GRID.n_cells + b.idx])
    mass = np.concatenate([b.mass, b.mass]) / 2
    order = np.argsort(key)
    prior = predict(SparseBelief(GRID, b.idx, b.mass, Bank(5.0, vel.shape[0], key[order], mass[order])),
                    replace(BANK, bank_switch=0.0))
    lik = np.exp(-0.5 * ((prior.centers() - [72.5, 127.5]) ** 2).sum(axis=1) / 3.0 ** 2)  # near the +10 m/s one
    post = reweight_bank(prior, lik, BANK.sparsity)
    assert bank_velocity(post, BANK.v_max)[1] > 9.0


def test_handoff_v3_carries_the_joint_belief():
    b = predict(_blob(70.0, 120.0), BANK)
    data = encode_handoff(Handoff.from_belief(3, 1, 2, b))
    bank = b.motion
    assert data[4] == 3 and len(data) == payload_bytes(bank.key.size, bank=True) == HEADER_BYTES + 6 + 8 * bank.key.size
    h = decode_handoff(data)
    got = h.belief()
    np.testing.assert_array_equal(got.motion.key, bank.key)
    np.testing.assert_allclose(got.motion.mass, bank.mass, rtol=1e-6)
    np.testing.assert_array_equal(got.idx, b.idx)
    np.testing.assert_allclose(got.mass, b.mass, rtol=1e-5)
    bad = bytearray(data)
    bad[HEADER_BYTES + 6:HEADER_BYTES + 10] = (bank.n_hyp * GRID.n_cells + 5).to_bytes(4, 'little')
    with pytest.raises(ValueError, match='joint'):
        decode_handoff(bytes(bad))
