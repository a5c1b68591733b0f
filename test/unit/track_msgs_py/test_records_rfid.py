"""RFID records ⇄ track_msgs: every layout round-trips exactly, NaN never reaches the wire, bad input is one line."""

from __future__ import annotations

import math

import pytest
from rclpy.serialization import deserialize_message, serialize_message

from track_core.rfid.protocol import Command, CommandKind, StepResult
from track_msgs import msg as tm
from track_msgs_py.records import RecordError
from track_msgs_py.records.rfid import (
    KIND_VALUES,
    RfidCommand,
    RfidFound,
    RfidStep,
    RfidUserStatus,
    read_command,
    read_step,
)
from track_msgs_py.stamps import stamp_to_ns


def _wire(msg):
    """Through CDR and back, as a subscriber gets it."""
    return deserialize_message(serialize_message(msg), type(msg))


def test_kind_constants_are_the_same_in_command_and_step():
    assert KIND_VALUES == {CommandKind.TURN: 1, CommandKind.MOVE: 2, CommandKind.DONE: 3}
    for name in ('TURN', 'MOVE', 'DONE'):
        assert getattr(tm.RfidCommand, name) == getattr(tm.RfidStep, name)


def test_command_round_trip_and_wire_fields():
    cmd = Command(CommandKind.TURN, 0.1 + 0.2, seq=7, repeat=True, reason='signal lost')
    msg = _wire(RfidCommand.from_command(cmd).to_msg(12.5))
    assert (msg.seq, msg.kind, msg.angle, msg.repeat, msg.reason) == (7, tm.RfidCommand.TURN, 0.1 + 0.2, True,
                                                                     'signal lost')
    assert msg.angle_deg == math.degrees(0.1 + 0.2) and stamp_to_ns(msg.header.stamp) == 12_500_000_000
    assert msg.header.frame_id == ''
    assert read_command(msg) == cmd
    assert RfidCommand.from_msg(msg) == RfidCommand.from_command(cmd)


def test_a_move_command_needs_only_seq_and_kind():
    assert read_command(tm.RfidCommand(seq=2, kind=tm.RfidCommand.MOVE)) == Command(CommandKind.MOVE, 0.0, 2)


@pytest.mark.parametrize(('fields', 'words'), [
    ({'kind': 0}, ['kind 0', '1 (turn), 2 (move), 3 (done)']),
    ({'kind': 7}, ['kind 7']),
    ({'seq': 0}, ['seq 0 < 1']),
    ({'angle': math.inf}, ['non-finite angle=inf']),
    ({'angle': math.nan}, ['non-finite angle=nan']),
    ({'angle_deg': math.nan}, ['non-finite angle_deg=nan']),
])
def test_bad_command_is_one_line(fields, words):
    msg = tm.RfidCommand(**{'seq': 1, 'kind': tm.RfidCommand.TURN, 'angle': 0.5, 'angle_deg': 28.6, **fields})
    with pytest.raises(RecordError) as exc:
        read_command(msg)
    assert '\n' not in str(exc.value) and all(w in str(exc.value) for w in words), str(exc.value)


def test_step_round_trip_exact_floats():
    res = StepResult(CommandKind.MOVE, 3, dphi=-1.0 / 3.0, turn=0.0, n_reads=151, n_outliers=2, ok=True,
                     reason='', found=False, dphi_std=0.1 + 0.2, relocks=2)
    rec = RfidStep.from_result(res, 0.5000000000000001)
    msg = _wire(rec.to_msg(3.25))
    assert (msg.seq, msg.kind, msg.dphi, msg.dphi_known, msg.dphi_std, msg.dphi_std_known, msg.relocks) == \
        (3, tm.RfidStep.MOVE, -1.0 / 3.0, True, 0.1 + 0.2, True, 2)
    assert (msg.n_reads, msg.n_outliers, msg.ok, msg.found, msg.duration) == (151, 2, True, False, 0.5000000000000001)
    assert RfidStep.from_msg(msg) == rec
    assert read_step(msg, Command(CommandKind.MOVE, seq=3)) == (res, 3)


def test_unknown_values_are_flags_on_the_wire_never_nan():
    """A TURN has no dφ; fixed noise has no dφ std; a core NaN turn is unknown too: 0 and *_known false."""
    res = StepResult(CommandKind.TURN, 4, dphi=math.nan, turn=math.nan, n_reads=3)
    msg = _wire(RfidStep.from_result(res, 0.25).to_msg(1.0))
    assert (msg.dphi, msg.dphi_known, msg.turn, msg.turn_known, msg.dphi_std, msg.dphi_std_known) == \
        (0.0, False, 0.0, False, 0.0, False)
    back, seq = read_step(msg, Command(CommandKind.TURN, seq=4))
    assert seq == 4 and math.isnan(back.dphi) and math.isnan(back.turn) and math.isnan(back.dphi_std)
    turn = RfidStep.from_result(StepResult(CommandKind.TURN, 5, turn=-0.75, n_reads=9), 0.5).to_msg(1.0)
    assert (turn.turn, turn.turn_known) == (-0.75, True)


def test_a_nan_dphi_sent_as_known_reaches_the_core_rule_as_nan():
    msg = RfidStep.from_result(StepResult(CommandKind.MOVE, 5, dphi=1.0, n_reads=3), 0.5).to_msg(1.0)
    msg.dphi = math.nan
    res, seq = read_step(msg, Command(CommandKind.MOVE, seq=5))
    assert seq == 5 and res.ok and math.isnan(res.dphi)  # the guidance's core words it: "phase difference is nan"


@pytest.mark.parametrize(('fields', 'words'), [
    ({'kind': 9}, ['kind 9']),
    ({'kind': 0}, ['kind 0']),
    ({'duration': math.nan}, ['non-finite duration=nan']),
    ({'dphi_std': math.inf, 'dphi_std_known': True}, ['non-finite dphi_std=inf']),
    ({'dphi_std': -0.1, 'dphi_std_known': True}, ['dphi_std=-0.1 is not > 0']),
])
def test_malformed_step_becomes_an_unusable_result_for_its_seq(fields, words):
    pending = Command(CommandKind.MOVE, seq=5)
    msg = RfidStep.from_result(StepResult(CommandKind.MOVE, 5, dphi=1.0, n_reads=3), 0.5).to_msg(1.0)
    for k, v in fields.items():
        setattr(msg, k, v)
    res, seq = read_step(msg, pending)
    assert seq == 5 and res.seq == 5 and res.kind is CommandKind.MOVE and not res.ok and not res.found
    assert res.reason.startswith('malformed step result') and math.isnan(res.dphi) and '\n' not in res.reason
    assert all(w in res.reason for w in words), res.reason
    with pytest.raises(RecordError):
        RfidStep.from_msg(msg)
    msg.seq = 6                                     # malformed and for another seq: the loop classifies it by 6
    assert read_step(msg, pending)[1] == 6


def test_user_status_and_found_round_trip():
    rec = RfidUserStatus(4, 10, 3, 5.25, 1, 0.1 + 0.05, True, -1.5, 2.0 / 3.0, math.pi)
    msg = _wire(rec.to_msg(7.0))
    assert msg.header.frame_id == 'map' and msg.heading == math.pi and msg.distance_to_tag_m == 0.1 + 0.05
    assert RfidUserStatus.from_msg(msg) == rec
    found = RfidFound(12, 11, 4, 10, 7, 0)
    msg = _wire(found.to_msg(7.0))
    assert (msg.seq, msg.moves, msg.turns, msg.updates, msg.resamples, msg.reinits) == (12, 11, 4, 10, 7, 0)
    assert RfidFound.from_msg(msg) == found


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
