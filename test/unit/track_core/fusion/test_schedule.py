import pytest

from track_core.fusion import StampSchedule


def test_instant_is_due_once_a_report_of_the_next_instant_arrives():
    s = StampSchedule(rate=1.0)
    assert s.push(1.0, 'a', 'a1') == [] and s.next_k == 1
    assert s.push(1.0, 'b', 'b1') == []
    assert s.push(1.5, 'a', 'a15') == []          # 1.5 < t_1 + 1/rate: t_1 not due yet
    assert s.push(2.0, 'b', 'b2') == [(1.0, ['a1', 'b1'])]   # a15 is stamped after t_1: held
    assert s.next_k == 2
    assert s.push(3.0, 'a', 'a3') == [(2.0, ['a15', 'b2'])]


def test_release_order_is_by_stamp_then_key_not_arrival():
    s = StampSchedule(rate=2.0)
    for t, key in ((0.5, 'z'), (0.5, 'a'), (0.0, 'm')):
        s.push(t, key, key)
    assert s.next_k == 1                           # first instant at or after the first stamp (0.5 s)
    assert s.push(1.0, 'x', 'x') == [(0.5, ['m', 'a', 'z'])]


def test_several_instants_at_once_and_a_jump_skips_the_empty_ones():
    s = StampSchedule(rate=1.0, max_skip=10)
    s.push(0.0, 'a', 'a0')
    assert s.push(3.0, 'a', 'a3') == [(0.0, ['a0']), (1.0, []), (2.0, [])]
    due = s.push(1000.0, 'a', 'a1000')             # jump > max_skip: only the instant before it is scored
    assert due == [(999.0, ['a3'])] and s.next_k == 1000


def test_bad_rate():
    with pytest.raises(ValueError, match='rate'):
        StampSchedule(0.0)


def test_with_streams_an_instant_waits_for_every_streams_watermark():
    """Across processes the radar's report for t = 2 can come before the network's for t = 1: the instant
    t_1 waits for both streams, so the release is the one a lock-step run gives, whatever the arrival order."""
    lockstep = StampSchedule(rate=1.0, streams=('radar', 'net'))
    late = StampSchedule(rate=1.0, streams=('radar', 'net'))
    for t in (1.0, 2.0, 3.0):
        got = lockstep.push(t, 'r', f'r{t:g}', 'radar') + lockstep.push(t, 'n', f'n{t:g}', 'net')
        assert got == ([] if t == 1.0 else [(t - 1.0, [f'n{t - 1:g}', f'r{t - 1:g}'])])
    assert late.push(1.0, 'r', 'r1', 'radar') == [] and late.push(2.0, 'r', 'r2', 'radar') == []
    assert late.next_k is None                     # the network has not spoken: no first instant yet
    assert late.push(3.0, 'r', 'r3', 'radar') == []
    assert late.push(1.0, 'n', 'n1', 'net') == []  # the network's watermark is t = 1: t_1 not complete
    assert late.push(2.0, 'n', 'n2', 'net') == [(1.0, ['n1', 'r1'])]
    assert late.push(3.0, 'n', 'n3', 'net') == [(2.0, ['n2', 'r2'])]


def test_a_silent_stream_is_waited_for_at_most_max_wait():
    s = StampSchedule(rate=1.0, streams=('radar', 'dead'), max_wait=3.0)
    assert [s.push(t, 'r', t, 'radar') for t in (1.0, 2.0, 3.0, 4.0)] == [[], [], [], []]
    assert s.push(5.0, 'r', 5.0, 'radar') == [(1.0, [1.0])]       # 5 - 3 = 2 ≥ t_1 + 1: scored without it
    with pytest.raises(ValueError, match='max_wait'):
        StampSchedule(1.0, max_wait=-1.0)
