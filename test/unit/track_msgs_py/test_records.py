"""The StatusRecord base: every annotated type round-trips, bad input is one line naming the key."""

from __future__ import annotations

from dataclasses import dataclass, field

import pytest

from track_msgs_py.records import DIAG_WARN, RecordError, StatusRecord, diagnostic_values


@dataclass(frozen=True)
class Example(StatusRecord):
    KIND = 'example'

    name: str
    count: int
    score: float
    flag: bool
    ids: tuple[int, ...]
    bits: tuple[float, ...] = field(default=(), metadata={'fmt': '{:.3g}'.format})
    previous: int | None = None
    distance: float = field(default=0.0, metadata={'key': 'distance_m'})


def test_round_trip_through_a_status():
    rec = Example('a b', 3, 0.1 + 0.2, True, (1, 22), (0.12345, 2.0), None, 1.5)
    st = rec.to_status('x', DIAG_WARN, 'msg', extra={'other': 7})
    v = diagnostic_values(st)
    assert v == {'name': 'a b', 'count': '3', 'score': '0.30000000000000004', 'flag': 'true', 'ids': '1 22',
                 'bits': '0.123 2', 'distance_m': '1.5', 'other': '7'}
    back = Example.from_status(st)
    assert back == Example('a b', 3, 0.1 + 0.2, True, (1, 22), (0.123, 2.0), None, 1.5)
    assert st.level == bytes([DIAG_WARN]) and st.name == 'x' and st.message == 'msg'


@pytest.mark.parametrize(('values', 'words'), [
    ({'count': '3', 'score': '1', 'flag': 'true', 'ids': ''}, ["missing key 'name'"]),
    ({'name': 'n', 'count': 'three', 'score': '1', 'flag': 'true', 'ids': ''}, ['count', 'three']),
    ({'name': 'n', 'count': '3', 'score': '1', 'flag': 'yes', 'ids': ''}, ['flag', 'yes']),
    ({'name': 'n', 'count': '3', 'score': '1', 'flag': 'true', 'ids': '1 x'}, ['ids', "'1 x'"]),
])
def test_bad_values_are_one_line_naming_the_key(values, words):
    with pytest.raises(RecordError) as exc:
        Example.from_values(values)
    text = str(exc.value)
    assert '\n' not in text and text.startswith('example:') and all(w in text for w in words), text


def test_optional_and_defaulted_keys_may_be_absent():
    rec = Example.from_values({'name': 'n', 'count': '1', 'score': 'nan', 'flag': 'false', 'ids': ''})
    assert rec.previous is None and rec.bits == () and rec.distance == 0.0 and rec.ids == ()
    assert 'previous' not in rec.to_values()
