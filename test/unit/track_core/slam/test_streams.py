"""``StreamMerger``: stamp order, the pause rule, flush on idle, the drain budget and the refusals; and
the saved cases, on which it gives what the ``slam`` node's merge gave before issue 12.

The fixture ``data/stream_merger_cases.json`` holds 300 random interleavings of inputs and scans
(pauses of either stream or none at all, duplicate and backwards stamps, stalled deliveries,
queued messages taken in one callback, idle ticks, a drain budget against a per-event cost). Its
expected outputs were produced by the OLD node path (SlamNode._accept/_push/_watermark/_drain/
_after_message/_on_idle of commit 3ac9344) with a fake clock that advances between callbacks and by
the cost of every event the (fake) filter processes. Issue 13 changed one rule on purpose: a
callback whose messages were all refused is no activity (a flood of refused messages must not hold
the idle flush back), so in 7 cases (the fixture's ``issue13`` key) the idle map flush comes one op
earlier; the events processed and their order are unchanged in every case.
"""

from __future__ import annotations

import json
import math
import zlib
from pathlib import Path

import numpy as np
import pytest

from track_core.slam.streams import INPUT, SCAN, StreamMerger, input_ok, scan_observations

CASES = json.loads((Path(__file__).parent / 'data' / 'stream_merger_cases.json').read_text())['cases']
STREAM = {0: INPUT, 1: SCAN}


class Clock:
    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        return self.t


def replay(case: dict) -> tuple[list, int]:
    """The case through a StreamMerger, fed as the node feeds it; the outputs in the fixture's layout."""
    pause_wall, flush_idle, budget, cost = (v / 1000 for v in case['p'])
    clock = Clock()
    m = StreamMerger(pause_wall, flush_idle, budget, now=clock())
    msgs = list(zip((STREAM[int(c)] for c in case['s']), case['t'], strict=True))
    processed, refused, reasons = [], [], []
    state = {'map_dirty': False}

    def step(stream, t_ns, i):
        clock.t += cost
        processed.append(i)
        ok = i % 11 != 7  # the fake filter of the generator refuses some events
        if ok and stream == SCAN:
            state['map_dirty'] = True
        return ok

    def offer(i):
        stream, t_ms = msgs[i]
        reason = m.offer(stream, t_ms * 10**6, i, clock())
        if reason is not None:
            refused.append(i)
            reasons.append(reason)

    outs, first = [], 0
    for kind, dt, count in case['ops']:
        clock.t += dt / 1000
        ids = range(first, first + count)
        first += count
        p0, r0, maps = len(processed), len(refused), 0
        if kind == 0:  # a message callback: its message, then everything queued, then the drain
            for i in ids:
                offer(i)
            m.end_callback(step, clock)
        else:  # the idle timer
            now = clock()
            for i in ids:
                offer(i)
            if m.on_idle(now, bool(count), step, clock) and state['map_dirty']:
                state['map_dirty'] = False
                maps = 1
        outs.append([processed[p0:], refused[r0:], maps, -1 if m.processed_ns is None else m.processed_ns // 10**6])
    return outs, zlib.crc32('\n'.join(reasons).encode())


def test_the_fixture_covers_the_rules():
    assert len(CASES) >= 300
    refused = sum(len(o[1]) for c in CASES for o in c['out'])
    flushes = sum(o[2] for c in CASES for o in c['out'])
    assert refused > 100 and flushes > 100
    assert any('1' not in c['s'] for c in CASES) and any('0' not in c['s'] for c in CASES)  # one stream absent


@pytest.mark.parametrize('k', range(len(CASES)))
def test_identical_to_the_old_node_path_on_saved_cases(k):
    case = CASES[k]
    outs, crc = replay(case)
    assert outs == case['out']
    assert crc == case['reasons_crc32']  # the refusal texts, byte for byte


def test_a_broken_merger_fails_the_saved_cases(monkeypatch):
    """The replay can fail: without the pause rule the outputs differ on some cases."""
    monkeypatch.setattr(StreamMerger, 'watermark', lambda self, now, heard=None: (
        None if None in self.last_ns.values() else min(self.last_ns.values())))
    assert sum(replay(c)[0] != c['out'] for c in CASES) > 10


# --- the rules, one by one ----------------------------------------------------------------------------

def _collect(out):
    return lambda stream, t_ns, payload: out.append((stream, t_ns, payload)) or True


def _never(t=0.0):
    return lambda: t


def test_release_in_stamp_order_up_to_the_watermark_scan_first_at_equal_stamps():
    m, out = StreamMerger(0.2, 0.5, 1.0, 0.0), []
    for stream, t, p in ((INPUT, 10, 'u10'), (INPUT, 20, 'u20'), (SCAN, 20, 's20'), (INPUT, 30, 'u30')):
        assert m.offer(stream, t, p, 0.0) is None
    assert m.watermark(0.0) == 20
    m.end_callback(_collect(out), _never())
    assert [p for _, _, p in out] == ['u10', 's20', 'u20'] and m.processed_ns == 20 and len(m) == 1


def test_backwards_and_late_stamps_are_refused_and_change_nothing():
    m, out = StreamMerger(0.2, 0.5, 1.0, 0.0), []
    m.offer(SCAN, 10, 'a', 0.0)
    m.offer(INPUT, 20, 'b', 0.0)
    assert 'time went backwards' in m.offer(INPUT, 19, 'x', 0.1)
    m.offer(INPUT, 30, 'c', 0.3)
    m.end_callback(_collect(out), _never(0.3))    # scans paused: everything up to the inputs' 30 is released
    assert m.processed_ns == 30 and [p for _, _, p in out] == ['a', 'b', 'c']
    assert 'was processed' in m.offer(SCAN, 25, 'y', 0.4)  # not backwards on its stream, but too late
    assert m.last_ns == {INPUT: 30, SCAN: 10} and len(m) == 0
    assert m.offer(INPUT, 30, 'dup', 0.4) is None  # an equal stamp is neither backwards nor late


def test_a_silent_stream_stops_holding_the_other_back_after_pause_wall_and_two_messages():
    m = StreamMerger(0.2, 5.0, 1.0, 0.0)
    m.offer(SCAN, 50, 's', 0.0)
    m.offer(INPUT, 60, 'u', 0.0)
    m.offer(INPUT, 70, 'u', 0.05)
    assert m.watermark(0.1) == 50            # scans silent for 0.1 s < pause_wall
    assert m.watermark(0.25) == 70           # silent 0.25 s and two inputs since the scan: paused
    m2 = StreamMerger(0.2, 5.0, 1.0, 0.0)
    m2.offer(SCAN, 50, 's', 0.0)
    m2.offer(INPUT, 60, 'u', 0.0)
    assert m2.watermark(10.0) == 50          # long silence but a single input meanwhile: still waits


def test_flush_on_idle_counts_from_the_end_of_the_last_callback():
    m, out = StreamMerger(10.0, 0.5, 1.0, 0.0), []
    m.offer(SCAN, 10, 's', 0.0)
    m.offer(INPUT, 20, 'u', 0.0)
    m.end_callback(_collect(out), _never(1.0))       # the callback ended at 1.0
    assert len(out) == 1 and len(m) == 1             # the input waits for the next scan
    assert not m.on_idle(1.4, False, _collect(out), _never(1.4)) and len(m) == 1
    assert m.on_idle(1.5, False, _collect(out), _never(1.5)) and len(m) == 0
    assert m.processed_ns == 20


def test_a_drain_stops_at_the_budget_and_the_next_call_continues():
    m, out, clock = StreamMerger(0.2, 0.5, 0.25, 0.0), [], [0.0]

    def step(stream, t_ns, payload):
        clock[0] += 0.1
        out.append(t_ns)
        return True

    for t in range(10):
        m.offer(SCAN, t, t, 0.0)
    assert m.drain(None, step, lambda: clock[0]) == 3   # 0.0, 0.1, 0.2 < 0.25; then 0.3: stop
    assert out == [0, 1, 2] and len(m) == 7
    m.drain(None, step, lambda: clock[0])
    assert out == list(range(6))


def test_an_event_the_filter_refuses_is_not_processed():
    m = StreamMerger(0.2, 0.5, 1.0, 0.0)
    m.offer(SCAN, 5, 'a', 0.0)
    m.offer(SCAN, 7, 'b', 0.0)
    m.drain(None, lambda s, t, p: p == 'a', _never())
    assert m.processed_ns == 5


def test_input_ok():
    assert input_ok(1.0, 0.3) and input_ok(-2.0, -1.5)
    assert not input_ok(math.nan, 0.0) and not input_ok(1.0, math.inf) and not input_ok(1.0, math.pi / 2)


def test_scan_observations_drop_clip_and_add_the_radius():
    r = np.array([10.0, -1.0, 5.0, 7.0, 8.0, 9.0])
    b = np.array([1.0, 1.0, math.pi + 1e-7, 4.0, 0.5, 0.2])
    d = np.array([0.4, 0.2, 0.2, 0.2, math.nan, 0.0])
    z, ok = scan_observations(r, b, d, (0.0, math.pi), 1e-6, add_radius=True)
    np.testing.assert_array_equal(ok, [True, False, True, False, False, True])
    np.testing.assert_allclose(z, [[10.2, 1.0], [5.1, math.pi], [9.0, 0.2]], rtol=0, atol=1e-12)
    z, ok = scan_observations(r, b, d, (0.0, math.pi), 0.0, add_radius=False)
    np.testing.assert_array_equal(ok, [True, False, False, False, True, True])
    np.testing.assert_array_equal(z[:, 0], [10.0, 8.0, 9.0])


def test_a_callback_of_refused_messages_is_no_activity():
    """Issue 13: refused offers change nothing, not even the idle clock, so a flood cannot hold the flush back."""
    m = StreamMerger(0.2, 0.5, 1.0, now=0.0)
    assert m.offer(INPUT, 10, 'a', 0.0) is None
    m.end_callback(lambda *a: True, lambda: 0.0)
    for k in range(1, 20):  # a flood of backwards stamps, one callback each, 0.01 s apart
        assert 'went backwards' in m.offer(INPUT, 5, 'b', 0.01 * k)
        m.end_callback(lambda *a: True, lambda k=k: 0.01 * k)
    assert m.last_activity == 0.0 and m.last_ns[INPUT] == 10
    assert m.on_idle(0.55, False, lambda *a: True, lambda: 0.55)  # idle 0.5 s after the last accepted message


def test_observations_beyond_the_bound_are_unusable():
    r, b, d = np.array([5.0, 1e308, 2e7, 6.0]), np.full(4, 1.0), np.array([0.3, 0.3, 0.3, 1e308])
    z, ok = scan_observations(r, b, d, (0.0, math.pi), 1e-6, True, bound=1e7)
    assert ok.tolist() == [True, False, False, False] and z.tolist() == [[5.15, 1.0]]
    _, ok = scan_observations(r, b, d, (0.0, math.pi), 1e-6, False, bound=1e7)
    assert ok.tolist() == [True, False, False, True]  # without add_radius the diameter is not read
    _, ok = scan_observations(r, b, d, (0.0, math.pi), 1e-6, True)  # no bound: as before
    assert ok.tolist() == [True, True, True, True]


def test_a_stream_whose_messages_are_refused_is_not_paused():
    """``heard``: a stream that delivers only refused messages is not silent, so the other stream is not
    released past it (its next valid event would otherwise be refused as late)."""
    m, out = StreamMerger(0.2, 10.0, 1.0, 0.0), []
    m.offer(SCAN, 10, 's10', 0.0)
    for k in range(1, 6):  # inputs go on; the scan stream delivers only refused messages
        m.offer(INPUT, 10 + 10 * k, f'u{10 + 10 * k}', 0.1 * k)
    heard = {INPUT: 0.5, SCAN: 0.5}
    assert m.watermark(0.5, heard) == 10 and m.watermark(0.5) is not None and m.watermark(0.5) > 10
    m.end_callback(_collect(out), _never(0.5), heard)
    assert m.processed_ns == 10
    assert m.offer(SCAN, 25, 's25', 0.6) is None  # the next valid scan is still in time
