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
