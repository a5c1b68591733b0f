"""The fuzzer's classes for typed protocol messages: out-of-window counters and unknown kinds."""

from __future__ import annotations

from track_experiments.fuzz.generate import _counter_kinds
from track_msgs.msg import RfidCommand, Track


def test_a_command_gets_seq_and_kind_attacks_that_change_only_that_field():
    tpl = RfidCommand(seq=5, kind=2)
    kinds = dict(_counter_kinds(tpl))
    assert set(kinds) == {'seq.max_u32', 'seq.ahead', 'seq.behind', 'seq.zero', 'kind.unknown'}
    assert kinds['seq.max_u32'](RfidCommand(seq=5), 0).seq == 0xFFFFFFFF
    assert kinds['seq.ahead'](RfidCommand(seq=5), 0).seq == 1005
    assert kinds['seq.behind'](RfidCommand(seq=5), 0).seq == 0
    hit = kinds['kind.unknown'](RfidCommand(seq=5, kind=2), 0)
    assert (hit.kind, hit.seq) == (200, 5)


def test_a_message_without_counters_gets_none():
    assert _counter_kinds(Track()) == []
