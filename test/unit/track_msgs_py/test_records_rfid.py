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


# --- /rfid/phase (issue 19: positions first) ---------------------------------------------------------

def test_phase_cloud_has_the_reads_positions_first_and_round_trips():
    import numpy as np
    from rclpy.serialization import deserialize_message, serialize_message
    from sensor_msgs.msg import PointCloud2, PointField

    from track_core.rfid.signal import PhaseStream
    from track_msgs_py.records.rfid import PHASE_FIELDS, RfidPhase

    xy = np.array([[10.0, 0.0], [9.75, 0.125], [9.5, 0.25]])  # float32-exact
    stream = PhaseStream(np.array([5.25, 5.5, 5.75]), np.array([0.5, 1.0, 3.0]), np.array([-60.0, -61.0, -62.5]),
                         5.0, 6.0, xy=xy)
    rec = RfidPhase.from_stream(7.5, stream, 5.0, 866.5e6, np.zeros(3))
    msg = deserialize_message(serialize_message(rec.to_msg()), PointCloud2)
    assert [(f.name, f.offset, f.datatype) for f in msg.fields[:3]] == [
        ('x', 0, PointField.FLOAT32), ('y', 4, PointField.FLOAT32), ('z', 8, PointField.FLOAT32)]
    assert [f.name for f in msg.fields[3:]] == list(PHASE_FIELDS) and msg.header.frame_id == 'map'
    back = RfidPhase.from_msg(msg)
    assert back.stamp == 7.5 and back.frame_id == 'map'
    np.testing.assert_array_equal(back.xy, xy)
    np.testing.assert_array_equal(back.t, [0.25, 0.5, 0.75])
    np.testing.assert_array_equal(back.carrier_mhz, [866.5] * 3)
    np.testing.assert_array_equal(back.phase, stream.phase)
    # a stream without positions (not the simulator's) puts every read at the given position
    bare = RfidPhase.from_stream(7.5, PhaseStream(stream.t, stream.phase, stream.rssi), 5.0, 866.5e6,
                                 np.array([1.0, 2.0, 0.3]))
    np.testing.assert_array_equal(bare.xy, [[1.0, 2.0]] * 3)
    with pytest.raises(ValueError, match='xy has shape'):
        PhaseStream(stream.t, stream.phase, stream.rssi, xy=xy[:2])


def test_phase_cloud_without_a_field_is_refused_in_one_line():
    import numpy as np

    from track_msgs_py.clouds import table_to_pointcloud2
    from track_msgs_py.records.rfid import RfidPhase

    old = table_to_pointcloud2(1.0, 'rfid_reader', {k: np.ones(2) for k in ('t', 'phase', 'rssi', 'carrier_mhz')})
    with pytest.raises(RecordError, match=r'rfid phase: needs float fields .* missing x, y') as exc:
        RfidPhase.from_msg(old)
    assert '\n' not in str(exc.value)
