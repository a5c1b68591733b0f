"""RFID records: every layout round-trips, keys and texts are the ones on the wire, bad input is one line."""

from __future__ import annotations

import math

import pytest
from diagnostic_msgs.msg import DiagnosticArray

from track_core.rfid.protocol import Command, CommandKind, StepResult
from track_msgs_py.records import DIAG_WARN, RecordError, diagnostic_values
from track_msgs_py.records.rfid import (
    RfidCommand,
    RfidFound,
    RfidStep,
    RfidUserStatus,
    read_command,
    read_step,
)


def _array(status) -> DiagnosticArray:
    return DiagnosticArray(status=[status])


def test_command_round_trip_and_wire_text():
    cmd = Command(CommandKind.TURN, 0.1 + 0.2, seq=7, repeat=True, reason='signal lost')
    st = RfidCommand.from_command(cmd).to_status('g/command', DIAG_WARN, 'words')
    assert diagnostic_values(st) == {'seq': '7', 'kind': 'turn', 'angle': repr(0.1 + 0.2), 'angle_deg': '17.19',
                                     'repeat': 'true', 'reason': 'signal lost'}
    assert list(diagnostic_values(st)) == ['seq', 'kind', 'angle', 'angle_deg', 'repeat', 'reason']
    assert read_command(_array(st)) == cmd


def test_command_needs_only_seq_and_kind():
    st = RfidCommand.from_values({'seq': '2', 'kind': 'move'}).to_status('x')
    assert read_command(_array(st)) == Command(CommandKind.MOVE, 0.0, 2)


@pytest.mark.parametrize(('values', 'words'), [
    ({'kind': 'move'}, ["'seq'"]),
    ({'seq': '1', 'kind': 'walk'}, ['walk', 'turn|move|done']),
    ({'seq': '0', 'kind': 'move'}, ['seq 0 < 1']),
    ({'seq': '1', 'kind': 'turn', 'angle': 'inf'}, ['non-finite angle']),
    ({'seq': '1', 'kind': 'turn', 'angle': 'left'}, ['angle', 'left']),
])
def test_bad_command_is_one_line(values, words):
    st = RfidCommand.from_values({'seq': '1', 'kind': 'move'}).to_status('x')
    st.values = [type(st.values[0])(key=k, value=v) for k, v in values.items()]
    with pytest.raises(RecordError) as exc:
        read_command(_array(st))
    assert '\n' not in str(exc.value) and all(w in str(exc.value) for w in words), str(exc.value)
    with pytest.raises(RecordError, match='no status'):
        read_command(DiagnosticArray())


def test_step_round_trip_exact_floats():
    res = StepResult(CommandKind.MOVE, 3, dphi=-1.0 / 3.0, turn=0.0, n_reads=151, n_outliers=2, ok=True,
                     reason='', found=False, dphi_std=0.1 + 0.2, relocks=2)
    rec = RfidStep.from_result(res, 0.5000000000000001)
    v = rec.to_values()
    assert list(v) == ['seq', 'kind', 'dphi', 'turn', 'n_reads', 'n_outliers', 'ok', 'reason', 'found', 'duration',
                       'dphi_std', 'relocks']
    assert v['dphi_std'] == repr(0.1 + 0.2) and v['relocks'] == '2'
    assert v['dphi'] == repr(-1.0 / 3.0) and v['ok'] == 'true' and v['found'] == 'false'
    assert RfidStep.from_values(v) == rec
    assert read_step(_array(rec.to_status('r/step')), Command(CommandKind.MOVE, seq=3)) == (res, 3)


def test_malformed_step_becomes_an_unusable_result_for_the_pending_command():
    pending = Command(CommandKind.MOVE, seq=5)
    good = RfidStep.from_result(StepResult(CommandKind.MOVE, 5, dphi=1.0, n_reads=3), 0.5).to_values()
    bad_kind = RfidStep.from_values(good).to_status('r')
    bad_kind.values[1].value = 'jump'
    res, seq = read_step(_array(bad_kind), pending)
    assert seq == 5 and res.seq == 5 and res.kind is CommandKind.MOVE and not res.ok and not res.found
    assert res.reason.startswith('malformed step result') and 'jump' in res.reason and math.isnan(res.dphi)
    bad_seq = RfidStep.from_values(good).to_status('r')
    bad_seq.values[0].value = 'five'
    res, seq = read_step(_array(bad_seq), pending)
    assert seq is None and res.seq == 5 and not res.ok and 'five' in res.reason
    res, seq = read_step(DiagnosticArray(), pending)
    assert seq is None and not res.ok and 'no status' in res.reason


def test_user_status_and_found_round_trip():
    rec = RfidUserStatus(4, 10, 3, 5.25, 1, 0.1 + 0.05, True, -1.5, 2.0 / 3.0, math.pi)
    v = rec.to_values()
    assert v['distance_m'] == '5.25' and v['found'] == 'true' and v['heading'] == repr(math.pi)
    assert RfidUserStatus.from_status(rec.to_status('r/user')) == rec
    found = RfidFound(12, 11, 4, 10, 7, 0)
    assert list(found.to_values()) == ['seq', 'moves', 'turns', 'updates', 'resamples', 'reinits']
    assert RfidFound.from_values(found.to_values()) == found
    with pytest.raises(RecordError, match="missing key 'heading'"):
        RfidUserStatus.from_values({k: x for k, x in v.items() if k != 'heading'})
