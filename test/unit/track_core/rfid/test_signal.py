"""Unwrapping against the geometric dφ of eq. 6: noise, outliers, both wrap ranges, lost signal."""

import math

import numpy as np
import pytest

from track_core.rfid.phase import PhaseModel
from track_core.rfid.signal import PhaseStream, StreamStatus, UnwrapConfig, naive_unwrap, process_move

PERIODS = [math.pi, 2 * math.pi]


def make_stream(pm: PhaseModel, start, end, rng, *, rate=300.0, speed=1.0, noise=None, outlier_prob=0.0,
                offset=1.234, t0=10.0):
    """Reads along a straight walk from ``start`` to ``end`` (tag at the origin), Poisson read times."""
    start, end = np.asarray(start, float), np.asarray(end, float)
    dur = np.hypot(*(end - start)) / speed
    t = np.cumsum(rng.exponential(1.0 / rate, int(rate * dur * 2 + 20)))
    t = t[t <= dur]
    xy = start + (t / dur)[:, None] * (end - start)
    d = np.hypot(xy[:, 0], xy[:, 1])
    ph = pm.phase(d, offset) + rng.normal(0.0, pm.s_theta if noise is None else noise, d.size)
    out = rng.random(d.size) < outlier_prob
    ph[out] = rng.uniform(0, pm.wrap_period, out.sum())
    return PhaseStream(t0 + t, pm.wrap(ph), np.full(d.size, -50.0), t0, t0 + dur), out


def walks():
    """(start, end): toward, away, oblique, and one passing 0.2 m from the tag (d not monotonic)."""
    return [((-5.0, 0.0), (-4.5, 0.0)), ((3.0, 4.0), (3.3, 4.4)), ((2.0, -7.0), (2.35, -6.64)),
            ((-0.25, 0.2), (0.25, 0.2))]


@pytest.mark.parametrize('period', PERIODS)
@pytest.mark.parametrize('walk', walks())
def test_noisy_stream_gives_the_geometric_dphi(period, walk):
    pm = PhaseModel(wrap_period=period)
    rng = np.random.default_rng(1)
    truth = float(pm.dphi(np.array(walk[0]), np.array(walk[1])))
    errs = []
    for _ in range(20):
        stream, _ = make_stream(pm, *walk, rng)
        est = process_move(stream, UnwrapConfig(period=period))
        assert est.ok, est.reason
        assert est.n_outliers <= 0.03 * est.n_reads      # a 4σ gate: a rare clean read is dropped
        errs.append(est.dphi - truth)
    errs = np.array(errs)
    # end fits over 15 reads: std ≈ 0.7 s_θ ≈ 0.07 rad; never a period off
    assert abs(errs.mean()) < 0.05
    assert np.max(np.abs(errs)) < 0.3


@pytest.mark.parametrize('period', PERIODS)
def test_outliers_are_rejected_where_the_naive_unwrap_slips(period):
    pm = PhaseModel(wrap_period=period)
    rng = np.random.default_rng(2)
    walk = ((-6.0, 1.0), (-5.52, 0.86))
    truth = float(pm.dphi(np.array(walk[0]), np.array(walk[1])))
    naive_bad = 0
    for _ in range(40):
        stream, out = make_stream(pm, *walk, rng, outlier_prob=0.05)
        est = process_move(stream, UnwrapConfig(period=period))
        assert est.ok, est.reason
        assert abs(est.dphi - truth) < 0.3
        # every injected outlier farther from the truth than the gate is dropped; few clean reads are
        f = ((stream.t - stream.t_start) / (stream.t_end - stream.t_start))[:, None]
        d_true = np.hypot(*(np.asarray(walk[0]) + f * (np.asarray(walk[1]) - np.asarray(walk[0]))).T)
        resid = np.abs((stream.phase - pm.wrap(pm.phase(d_true, 1.234)) + period / 2) % period - period / 2)
        far = out & (resid > 0.2 * period)
        assert not np.any(est.accepted[far])
        assert np.sum(~est.accepted & ~out) <= 0.03 * est.n_reads
        naive = naive_unwrap(stream.phase, period)
        naive_bad += abs(-(naive[-1] - naive[0]) - truth) > 1.0
    assert naive_bad > 0      # the textbook unwrap does slip by a period with these outliers


def test_outlier_at_the_first_read_does_not_take_the_lock():
    pm = PhaseModel(wrap_period=math.pi)
    rng = np.random.default_rng(3)
    stream, _ = make_stream(pm, (-4.0, 0.0), (-3.5, 0.0), rng)
    ph = stream.phase.copy()
    ph[0] = pm.wrap(ph[0] + math.pi / 2)
    est = process_move(PhaseStream(stream.t, ph, stream.rssi, stream.t_start, stream.t_end))
    assert est.ok and not est.accepted[0] and est.n_outliers >= 1
    assert est.dphi == pytest.approx(float(pm.dphi(np.array([-4.0, 0.0]), np.array([-3.5, 0.0]))), abs=0.3)


def test_empty_stream_is_signal_lost():
    est = process_move(PhaseStream.empty(0.0, 0.5))
    assert est.status is StreamStatus.SIGNAL_LOST and math.isnan(est.dphi)
    assert 'no reads' in est.reason


def test_too_few_reads_and_uncovered_step_are_signal_lost():
    pm = PhaseModel()
    rng = np.random.default_rng(4)
    stream, _ = make_stream(pm, (-4.0, 0.0), (-3.5, 0.0), rng)
    few = PhaseStream(stream.t[:5], stream.phase[:5], stream.rssi[:5])
    assert process_move(few).status is StreamStatus.SIGNAL_LOST
    half = stream.t <= stream.t_start + 0.25       # reads stop half-way (tag left the beam)
    cut = PhaseStream(stream.t[half], stream.phase[half], stream.rssi[half], stream.t_start, stream.t_end)
    est = process_move(cut)
    assert est.status is StreamStatus.SIGNAL_LOST and 'before the step ended' in est.reason


def test_a_burst_of_outliers_loses_the_lock():
    """Reads that disagree with the track and with each other (uniform phases) are a run of outliers."""
    pm = PhaseModel()
    rng = np.random.default_rng(5)
    stream, _ = make_stream(pm, (-4.0, 0.0), (-3.5, 0.0), rng, noise=0.0)
    ph = stream.phase.copy()
    ph[40:60] = rng.uniform(0.0, pm.wrap_period, 20)
    est = process_move(PhaseStream(stream.t, ph, stream.rssi, stream.t_start, stream.t_end))
    assert est.status is StreamStatus.INVALID and 'lock lost' in est.reason


def test_a_consistent_burst_relocks_in_and_out():
    """20 reads shifted by the same 1 rad agree with each other: a lasting step, and a step back (issue 14).

    The paper's processing (``relock_reads`` 0, the default) loses the lock (more than 8 outliers in a
    row); with re-locking on, both steps re-lock and,
    bridged by their wrapped differences (+1 then −1 rad), cancel in dφ.
    """
    pm = PhaseModel()
    rng = np.random.default_rng(5)
    stream, _ = make_stream(pm, (-4.0, 0.0), (-3.5, 0.0), rng, noise=0.0)
    truth = float(pm.dphi(np.array([-4.0, 0.0]), np.array([-3.5, 0.0])))
    ph = stream.phase.copy()
    ph[40:60] = pm.wrap(ph[40:60] + 1.0)
    est = process_move(PhaseStream(stream.t, ph, stream.rssi, stream.t_start, stream.t_end),
                       UnwrapConfig(relock_reads=5))
    assert est.ok and est.relocks == 2
    assert est.dphi == pytest.approx(truth, abs=0.02)
    old = process_move(PhaseStream(stream.t, ph, stream.rssi, stream.t_start, stream.t_end),
                       UnwrapConfig(relock_reads=0))
    assert old.status is StreamStatus.INVALID and 'lock lost' in old.reason


def test_a_long_gap_is_invalid():
    pm = PhaseModel()
    rng = np.random.default_rng(6)
    stream, _ = make_stream(pm, (-4.0, 0.0), (-3.5, 0.0), rng)
    keep = (stream.t < stream.t_start + 0.1) | (stream.t > stream.t_start + 0.35)
    est = process_move(PhaseStream(stream.t[keep], stream.phase[keep], stream.rssi[keep], stream.t_start,
                                   stream.t_end))
    assert est.status is StreamStatus.INVALID and 'without a usable read' in est.reason


def test_non_finite_or_unordered_reads_are_invalid():
    t = np.linspace(0, 0.5, 100)
    ph = np.full(100, 1.0)
    ph[10] = np.nan
    assert process_move(PhaseStream(t, ph, ph)).status is StreamStatus.INVALID
    assert 'order' in process_move(PhaseStream(t[::-1], np.ones(100), np.ones(100))).reason


@pytest.mark.parametrize('noise', ['fixed', 'online', 'robust'])
def test_reads_stamped_in_batches_are_refused_with_the_reason(noise):
    """A reader that stamps a whole report with one instant: no phase rate, no end fit; refused, not guessed."""
    pm = PhaseModel()
    stream, _ = make_stream(pm, (-4.0, 0.0), (-3.5, 0.0), np.random.default_rng(7))
    batched = stream.t_start + np.floor((stream.t - stream.t_start) / 0.1) * 0.1   # one stamp per 0.1 s report
    cfg = UnwrapConfig.for_model(pm, noise=noise)
    good = process_move(stream, cfg)
    est = process_move(PhaseStream(batched, stream.phase, stream.rssi, stream.t_start, stream.t_end), cfg)
    assert good.ok and est.status is StreamStatus.INVALID and 'distinct times' in est.reason


def test_stream_lengths_must_match_and_config_is_checked():
    with pytest.raises(ValueError, match='lengths'):
        PhaseStream(np.zeros(3), np.zeros(2), np.zeros(3))
    with pytest.raises(ValueError, match='gate'):
        UnwrapConfig(gate=0.6)
