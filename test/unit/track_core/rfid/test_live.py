"""track_core.rfid.live: reads cut into commanded actions by their reader time, whatever the arrival latency."""

from __future__ import annotations

import math

import numpy as np
import pytest

from track_core.rfid.live import LiveActions, channel_carriers
from track_core.rfid.phase import PhaseModel
from track_core.rfid.protocol import Command, CommandKind
from track_core.rfid.signal import PhaseProcessor, UnwrapConfig

LLRP = PhaseModel.with_wrap('2pi', convention='llrp')
OMEGA = 8.0          # rad/s: the phase of a user walking away from the tag (LLRP: rises with distance)
OFFSET = 1.7e9       # reader clock − local clock [s]


def _actions(move_s: float = 0.5, turn_read_s: float = 0.2, latency_s: float = 0.2) -> LiveActions:
    return LiveActions(PhaseProcessor(UnwrapConfig.real_reader(LLRP)), move_s, turn_read_s, latency_s)


def _reads(t0: float, t1: float, rate: float = 300.0, seed: int = 0, latency: float = 0.0, bunch: float = 0.0):
    """Reads taken in [t0, t1) (local clock), phase OMEGA·t wrapped, arriving ``latency`` later plus up to
    ``bunch`` s of random delay, released in bursts (a busy client thread), in arrival order."""
    rng = np.random.default_rng(seed)
    taken = np.arange(t0, t1, 1.0 / rate)
    phase = np.mod(OMEGA * taken + 0.01 * rng.standard_normal(taken.size), 2.0 * math.pi)
    arrival = taken + latency + (np.ceil(taken / bunch) * bunch - taken if bunch else 0.0)
    arrival = arrival + rng.uniform(0.0, 0.002, taken.size)
    order = np.argsort(arrival, kind='stable')
    n = taken.size
    return arrival[order], (taken + OFFSET)[order], phase[order], np.full(n, -50.0), np.full(n, LLRP.carrier_hz)


def _feed(live: LiveActions, reads, upto: float) -> None:
    """The reads that have arrived by ``upto`` (local clock)."""
    arrival = reads[0]
    sel = arrival <= upto
    live.add(*(v[sel] for v in reads))


def test_a_move_is_the_reads_taken_in_its_window_and_its_dphi_is_the_phase_change():
    live = _actions()
    live.add(*_reads(0.0, 1.0))                                  # nobody moving: idle
    assert live.idle_reads == 300 and live.offset == pytest.approx(OFFSET - 0.0, abs=0.003)
    live.start(Command(CommandKind.MOVE, seq=1), 1.0)
    reads = _reads(1.0, 1.8, seed=1)
    _feed(live, reads, 1.5)
    assert live.take_due(1.5) is None                            # waits latency_s for reads on their way
    _feed(live, tuple(v[reads[0] > 1.5] for v in reads), 1.8)
    a = live.take_due(1.7)
    n = len(a.stream)
    assert a.result.kind is CommandKind.MOVE and a.result.seq == 1 and a.result.ok, a.result
    assert a.result.n_reads == n and abs(n - 150) <= 1 and a.duration == 0.5      # 300 reads/s × 0.5 s
    assert a.stream.t_start == pytest.approx(1.0 + OFFSET, abs=0.003)
    assert a.result.dphi == pytest.approx(OMEGA * 0.5, abs=0.05)  # 4 rad: wraps inside the step
    assert live.idle_reads == 300 + (240 - n) and not live.busy


@pytest.mark.parametrize(('latency', 'bunch'), [(0.05, 0.0), (0.02, 0.1), (0.15, 0.04)])
def test_late_and_bunched_reads_still_give_the_dphi(latency, bunch):
    """Reads arriving late and in bursts belong to the window of their reader time."""
    live = _actions(latency_s=latency + bunch + 0.01)
    reads = _reads(0.0, 1.5, seed=3, latency=latency, bunch=bunch)
    _feed(live, reads, 0.5)                                      # what has arrived when the command comes
    live.start(Command(CommandKind.MOVE, seq=1), 0.5)
    for upto in np.arange(0.52, 1.5, 0.02):                     # the node's timer
        _feed(live, tuple(v[(reads[0] > upto - 0.02) & (reads[0] <= upto)] for v in reads), upto)
        a = live.take_due(upto)
        if a is not None:
            break
    assert a is not None and a.result.ok, a
    assert a.result.dphi == pytest.approx(OMEGA * 0.5, abs=0.05) and abs(a.result.n_reads - 150) <= 2


def test_the_answer_comes_with_the_first_later_read_and_a_starved_process_loses_no_read():
    """Due as soon as a read taken after the window has arrived, before ``latency_s``; a process that ran
    nothing for a second (the reads waiting in the socket) still cuts the window by reader time."""
    live = _actions(latency_s=5.0)
    live.add(*_reads(0.0, 0.5))
    live.start(Command(CommandKind.MOVE, seq=1), 0.5)
    reads = _reads(0.5, 1.1, seed=4)
    _feed(live, tuple(v[reads[1] <= 1.0 + OFFSET - 0.01] for v in reads), 1.2)
    assert live.take_due(1.2) is None                            # no read after the window yet, deadline at 6 s
    _feed(live, tuple(v[reads[1] > 1.0 + OFFSET - 0.01] for v in reads), 1.2)
    a = live.take_due(1.2)
    assert a is not None and a.result.ok and abs(a.result.n_reads - 150) <= 1, a
    live.start(Command(CommandKind.MOVE, seq=2), 2.0)
    late = _reads(2.0, 2.6, seed=5)
    live.add(late[0] * 0.0 + 3.5, *late[1:])                     # starved: all of them arrive at 3.5 s
    a = live.take_due(3.5)
    assert a.result.ok and abs(a.result.n_reads - 150) <= 1 and a.result.dphi == pytest.approx(4.0, abs=0.05)
    live.start(Command(CommandKind.MOVE, seq=3), 4.0)            # the tag no longer read: the deadline answers
    assert live.take_due(9.4) is None and not live.take_due(9.5).result.ok


def test_a_turn_is_the_asked_turn_checked_by_reads_and_done_answers_at_once():
    live = _actions()
    live.start(Command(CommandKind.TURN, math.radians(30.0), 2), 0.0)
    live.add(*_reads(0.0, 0.1))
    a = live.take_due(0.4)
    assert a.result.turn == pytest.approx(math.radians(30.0)) and a.result.ok and a.result.n_reads == 30
    live.start(Command(CommandKind.TURN, -1.0, 3), 1.0)
    assert not live.take_due(1.4).result.ok                     # no read after the turn: tag not read this way
    live.start(Command(CommandKind.DONE, seq=4), 2.0)
    assert live.take_due(2.0).result.kind is CommandKind.DONE


def test_confirm_closes_a_move_early_and_one_action_at_a_time():
    live = _actions(move_s=5.0, latency_s=0.0)
    assert not live.confirm(0.0)
    live.start(Command(CommandKind.MOVE, seq=1), 0.0)
    with pytest.raises(RuntimeError, match='still open'):
        live.start(Command(CommandKind.MOVE, seq=2), 0.1)
    live.add(*_reads(0.0, 0.6))
    assert live.confirm(0.5) and live.take_due(0.5).duration == 0.5
    with pytest.raises(ValueError, match='move_s'):
        LiveActions(PhaseProcessor(UnwrapConfig.real_reader(LLRP)), 0.0, 0.1)


def test_a_reader_clock_that_steps_back_is_learnt_again():
    live = _actions()
    live.add(*_reads(0.0, 0.2))
    r = _reads(1.0, 1.2)
    live.add(r[0], r[1] - 100.0, *r[2:])                        # the reader restarted with another clock
    assert live.offset == pytest.approx(OFFSET - 100.0, abs=0.003)


def test_channel_index_to_carrier_by_the_hop_table():
    out = channel_carriers(np.array([1, 3, 0, 9]), (902.75e6, 903.25e6, 903.75e6))
    np.testing.assert_array_equal(out[:2], [902.75e6, 903.75e6])
    assert np.isnan(out[2:]).all()
