"""IDSQ records: a sensor's reading (track_msgs IdsqReading) and the protocol messages (IdsqHandoff,
IdsqAck, IdsqRevoke, IdsqLeaderEvent) round-trip exactly, also through CDR (rclpy.serialization), and
hostile ones are refused with one line; the belief cloud and the sensor layout round-trip exactly."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from rclpy.serialization import deserialize_message, serialize_message

from track_msgs.msg import IdsqLeaderEvent as IdsqLeaderEventMsg
from track_msgs.msg import IdsqReading as IdsqReadingMsg
from track_msgs_py.records import RecordError
from track_msgs_py.records.idsq import (
    LAYOUT_FIELDS,
    IdsqAck,
    IdsqHandoff,
    IdsqLeaderEvent,
    IdsqReading,
    IdsqRevoke,
    layout_to_pointcloud2,
    pointcloud2_to_layout,
    received_handoff,
)


def cdr(msg):
    """Serialise and deserialise: what a subscriber or a bag reader gets."""
    return deserialize_message(serialize_message(msg), type(msg))


# --- the reading ----------------------------------------------------------------------------------

@pytest.mark.parametrize('through_cdr', [False, True])
def test_a_reading_round_trips_and_its_direction_is_rep103(through_cdr):
    """A DOA bearing θ (clockwise from north) travels as a REP-103 direction (counter-clockwise from east):
    north-east (θ = π/4) is π/4 either way, east (θ = π/2) is 0, north-west (θ = -π/4) is 3π/4; the record
    reads it back to θ within an ulp, as ``readings.as_received`` says, and every field exactly."""
    from track_core.idsq.readings import Reading, as_received

    for theta, direction in ((math.pi / 4, math.pi / 4), (math.pi / 2, 0.0), (-math.pi / 4, 3 * math.pi / 4),
                             (math.pi, -math.pi / 2)):
        rec = IdsqReading.of_reading(1000.5, Reading(3, 7, True, 12.5, theta, 0.05))
        assert rec.direction == pytest.approx(direction, abs=1e-15) and rec.amplitude == 12.5
        msg = rec.to_msg()
        back = IdsqReading.from_msg(cdr(msg) if through_cdr else msg)
        assert back == rec and back.bearing == as_received(theta) == back.z
        assert abs(back.bearing - theta) <= 4.5e-16 and msg.type == IdsqReadingMsg.DOA
    ac = IdsqReading.of_reading(1000.5, Reading(3, 2, False, 9.75))
    msg = ac.to_msg()
    back = IdsqReading.from_msg(cdr(msg) if through_cdr else msg)
    assert back == dataclasses.replace(ac) and back.z == 9.75 and math.isnan(back.direction)
    assert msg.type == IdsqReadingMsg.ACOUSTIC and msg.header.frame_id == 'map'


def _reading(**fields) -> IdsqReadingMsg:
    msg = IdsqReading(1000.5, 4, True, 3.0, 0.5, 0.05).to_msg()
    for k, v in fields.items():
        setattr(msg, k, v)
    return msg


@pytest.mark.parametrize(('fields', 'words'), [
    ({'type': 7}, 'type=7 is neither'),
    ({'direction': math.nan}, 'direction=nan must be finite'),
    ({'direction_std': 0.0}, 'direction_std=0.0 must be finite and > 0'),
    ({'direction_std': math.inf}, 'direction_std=inf'),
    ({'amplitude': math.inf}, 'amplitude=inf must be finite'),
    ({'type': IdsqReadingMsg.ACOUSTIC, 'amplitude': math.nan}, 'amplitude=nan must be finite (an acoustic'),
])
def test_a_hostile_reading_is_refused_with_one_line(fields, words):
    with pytest.raises(RecordError) as exc:
        IdsqReading.from_msg(_reading(**fields))
    assert words in str(exc.value) and '\n' not in str(exc.value) and str(exc.value).startswith('idsq reading: ')


def test_a_doa_reading_in_another_frame_is_refused_and_one_without_a_frame_is_map():
    msg = _reading()
    msg.header.frame_id = 'doa_array_4'
    with pytest.raises(RecordError, match="frame_id='doa_array_4'"):
        IdsqReading.from_msg(msg)
    msg.header.frame_id = ''
    assert IdsqReading.from_msg(msg).frame_id == 'map'


def test_a_reading_for_another_sensor_or_type_names_the_problem():
    """The sensor-specific checks (the stamp's step and the horizon are the ledger's: ``reading_problem``)."""
    doa = IdsqReading.from_msg(_reading())
    assert doa.problem(4, True) is None and math.isnan(IdsqReading.from_msg(_reading(amplitude=math.nan)).amplitude)
    assert doa.problem(5, True) == 'sensor_id: 4 is not this sensor (5)'
    assert doa.problem(4, False) == 'type: DOA reading for an acoustic sensor'
    ac = IdsqReading(1.0, 4, False, 2.0)
    assert ac.problem(4, True) == 'type: ACOUSTIC reading for a DOA sensor'


# --- ack and revoke -------------------------------------------------------------------------------

@pytest.mark.parametrize('through_cdr', [False, True])
def test_ack_and_nack_round_trip(through_cdr):
    ack, nack = IdsqAck.reply(4, 2, 7, None, t=1002.5), IdsqAck.reply(4, 2, 7, 'wrong grid', t=1002.5)
    assert (ack.accepted, ack.result, ack.reason) == (True, 'ack', '')
    assert (nack.accepted, nack.result, nack.reason) == (False, 'nack', 'wrong grid')
    for rec in (ack, nack):
        msg = rec.to_msg()
        assert (msg.header.stamp.sec, msg.header.stamp.nanosec) == (1002, 500_000_000)
        assert IdsqAck.from_msg(cdr(msg) if through_cdr else msg) == rec


@pytest.mark.parametrize('reason', ['two\nlines', 'x' * 1001, 'bell\x07'])
def test_a_nack_whose_reason_is_not_one_short_line_is_refused(reason):
    msg = IdsqAck.reply(4, 2, 7, 'ok').to_msg()
    msg.reason = reason
    with pytest.raises(RecordError) as exc:
        IdsqAck.from_msg(msg)
    assert 'idsq ack: reason must be one printable line' in str(exc.value) and '\n' not in str(exc.value)


def test_an_absurd_step_is_stamped_zero():
    """(A reply to a handoff of step 0xFFFFFFFF: its step time does not fit a stamp.)"""
    msg = IdsqAck.reply(0xFFFFFFFF, 2, 7, 'window', t=0.5 * 2**32).to_msg()
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec, msg.step) == (0, 0, 0xFFFFFFFF)


def test_revoke_round_trips():
    rec = IdsqRevoke(7, 2, 5, t=12.0)
    assert IdsqRevoke.from_msg(cdr(rec.to_msg())) == rec


# --- leader events ----------------------------------------------------------------------------------

def test_step_event_round_trips_exactly_and_its_absent_fields_are_marked():
    scores = (0.123456789, 2.0, 1e-7)
    ev = IdsqLeaderEvent('step', 5, 3, 9, previous=-1, z=12.345678901, updated=True, belief_size=42,
                         spread_m2=123.25, candidates=(9, 4, 1), mi_bits=scores, handoff_bytes=200, t=3.0)
    msg = ev.to_msg()
    assert (msg.event, msg.failed, msg.reason, list(msg.tried)) == (IdsqLeaderEventMsg.STEP, -1, '', [])
    back = IdsqLeaderEvent.from_msg(cdr(msg))
    assert back == ev and back.mi_bits == scores  # float64 on the wire: exact
    assert back.tried is None and back.failed is None and back.reason is None


@pytest.mark.parametrize('ev', [
    IdsqLeaderEvent('reselect', 7, 2, 5, failed=4, reason='timeout', handoff_bytes=96),
    IdsqLeaderEvent('self', 7, 2, 2, tried=(4, 5)),
    IdsqLeaderEvent('void', 8, 2, 2, previous=4),
])
def test_reselect_self_and_void_events_round_trip(ev):
    msg = ev.to_msg()
    assert math.isnan(msg.z) and math.isnan(msg.spread_m2) and msg.belief_size == 0
    assert IdsqLeaderEvent.from_msg(cdr(msg)) == ev


def test_an_event_refuses_fields_it_does_not_carry_and_unknown_codes():
    with pytest.raises(ValueError, match='a self event does not carry failed'):
        IdsqLeaderEvent('self', 7, 2, 2, tried=(4,), failed=3)
    with pytest.raises(ValueError, match='event'):
        IdsqLeaderEvent('lead', 1, 2, 3)
    msg = IdsqLeaderEvent('self', 7, 2, 2, tried=(4,)).to_msg()
    msg.event = 9
    with pytest.raises(RecordError, match=r'event code 9 is not one of 0 \(step\)'):
        IdsqLeaderEvent.from_msg(msg)
    msg = IdsqLeaderEvent('step', 5, 3, 9, previous=-1, z=1.0, updated=True, belief_size=4, spread_m2=1.0,
                          candidates=(9, 4), mi_bits=(0.5, 0.25)).to_msg()
    msg.mi_bits = [0.5]
    with pytest.raises(RecordError, match='2 candidates but 1 scores'):
        IdsqLeaderEvent.from_msg(msg)


# --- the handoff -----------------------------------------------------------------------------------

def _handoff(motion=None, **kw):
    from track_core.idsq import GridSpec, Handoff

    grid = GridSpec.for_field()
    h = Handoff(4, 1, 2, grid, np.array([3, 8, 40]), np.array([0.5, 0.3, 0.2]), motion)
    return dataclasses.replace(h, **kw)


def _same(a, b) -> None:
    assert (a.step, a.sender, a.receiver, a.grid) == (b.step, b.sender, b.receiver, b.grid)
    np.testing.assert_array_equal(a.idx, b.idx)
    np.testing.assert_array_equal(a.mass, b.mass)


@pytest.mark.parametrize('kind', ['grid', 'motion', 'bank'])
def test_a_handoff_message_carries_what_the_package_bytes_carry(kind):
    """Through CDR, every version gives the receiver the belief the binary package gives it, to the bit."""
    from track_core.idsq import Motion, TrackerParams, decode_handoff, encode_handoff, predict
    from track_core.idsq.handoff import Handoff

    h = _handoff(Motion(np.array([1.25, -6.123456789]), 7) if kind == 'motion' else None)
    if kind == 'bank':
        h = Handoff.from_belief(4, 1, 2, predict(h.belief(), TrackerParams(prediction='bank')))
    msg = cdr(IdsqHandoff.from_handoff(1002.5, h).to_msg())
    assert msg.version == {'grid': 1, 'motion': 2, 'bank': 3}[kind] and msg.header.frame_id == 'map'
    rec = IdsqHandoff.from_msg(msg)
    assert rec.t == 1002.5 and rec.package_bytes == len(encode_handoff(h))
    got, want = received_handoff(msg), decode_handoff(encode_handoff(h))
    _same(got, want)
    if kind == 'motion':
        np.testing.assert_array_equal(got.motion.velocity, want.motion.velocity)
        assert got.motion.velocity[1] == float(np.float32(-6.123456789)) and got.motion.count == 7
    if kind == 'bank':
        np.testing.assert_array_equal(got.motion.key, want.motion.key)
        np.testing.assert_array_equal(got.motion.mass, want.motion.mass)


def _hostile(change):
    msg = IdsqHandoff.from_handoff(3.0, _handoff()).to_msg()
    change(msg)
    return received_handoff(cdr(msg))


@pytest.mark.parametrize(('change', 'reason'), [
    (lambda m: setattr(m, 'version', 7), 'unknown handoff version 7, expected one of 1, 2, 3'),
    (lambda m: setattr(m, 'mass', [0.5, 0.5]), 'handoff has 3 cells but 2 masses'),
    (lambda m: setattr(m, 'cells', []), 'handoff has 0 cells but 3 masses'),
    (lambda m: setattr(m, 'velocity_x', 2.0), 'velocity/observations are set in a version-1 handoff'),
    (lambda m: setattr(m, 'bank_hypotheses', 9), 'bank_spacing/hypotheses are set in a version-1 handoff'),
    (lambda m: setattr(m, 'grid_cell', math.nan), 'bad grid in handoff: cell=nan'),
    (lambda m: setattr(m, 'grid_nx', 0), 'bad grid in handoff: nx=0'),
    (lambda m: setattr(m.header, 'frame_id', 'odom'), "idsq handoff: header.frame_id='odom'"),
    (lambda m: (setattr(m, 'version', 2), setattr(m, 'velocity_x', math.inf)), 'bad motion in handoff'),
    (lambda m: (setattr(m, 'version', 3), setattr(m, 'bank_spacing', math.nan), setattr(m, 'bank_hypotheses', 9)),
     'bad joint belief in handoff: bad bank lattice nan'),
])
def test_an_unreadable_handoff_is_one_line_with_its_address(change, reason):
    """Refused before the ledger: the reason, and the address the typed message always has (the nack)."""
    from track_core.idsq.handoff import Unusable

    got = _hostile(change)
    assert isinstance(got, Unusable) and got.reason.startswith(reason) and '\n' not in got.reason, got
    assert got.address == (1, 2, 4)


def test_a_readable_handoff_with_a_bad_belief_is_the_ledger_s_to_refuse():
    """NaN mass reads (the ledger's validate_handoff refuses it: one place for both wire forms)."""
    from track_core.idsq import GridSpec, validate_handoff

    got = _hostile(lambda m: m.mass.__setitem__(1, math.nan))
    assert 'non-finite' in validate_handoff(got, GridSpec.for_field(), 8, receiver=2)


def test_belief_cloud_is_xyz_then_mass_and_round_trips():
    from sensor_msgs.msg import PointField

    from track_msgs_py.clouds import pointcloud2_to_table, table_to_pointcloud2
    from track_msgs_py.records.idsq import IdsqBelief

    xy, p = np.array([[12.5, 30.0], [17.5, 30.0]]), np.array([0.25, 0.75])
    msg = IdsqBelief(4.0, xy, p).to_msg()
    assert [(f.name, f.offset, f.datatype) for f in msg.fields] == [
        ('x', 0, PointField.FLOAT32), ('y', 4, PointField.FLOAT32), ('z', 8, PointField.FLOAT32),
        ('p', 12, PointField.FLOAT32)]
    assert not pointcloud2_to_table(msg)['z'].any() and msg.header.frame_id == 'map'
    back = IdsqBelief.from_msg(msg)
    assert back.t == 4.0
    np.testing.assert_array_equal(back.xy, xy)
    np.testing.assert_array_equal(back.p, p)
    with pytest.raises(RecordError, match=r'idsq belief: .*missing p'):
        IdsqBelief.from_msg(table_to_pointcloud2(0.0, 'map', {'x': [0.0], 'y': [0.0]}))


# --- the sensor layout and the handoff bytes ---------------------------------------------

@pytest.mark.parametrize('through_cdr', [False, True])
def test_idsq_layout_round_trip_is_exact(through_cdr):
    from sensor_msgs.msg import PointField

    from track_core.idsq import SensorLayout
    from track_msgs_py.clouds import pointcloud2_to_table

    rng = np.random.default_rng(3)
    layout = SensorLayout(rng.uniform(0.0, 150.0, (12, 2)) + 1e-9 * rng.standard_normal((12, 2)),
                          rng.random(12) < 0.3, 40.0)
    msg = layout_to_pointcloud2(1.5, layout)
    assert [f.name for f in msg.fields] == ['x', 'y', 'z', *LAYOUT_FIELDS] and msg.width == 12
    assert [(f.offset, f.datatype) for f in msg.fields[:3]] == [(0, PointField.FLOAT32), (4, PointField.FLOAT32),
                                                               (8, PointField.FLOAT32)]
    assert all(f.datatype == PointField.FLOAT64 and f.offset % 8 == 0 for f in msg.fields[3:])
    table = pointcloud2_to_table(msg)
    np.testing.assert_array_equal(table['x'], layout.positions[:, 0].astype(np.float32))
    assert not table['z'].any()
    back = pointcloud2_to_layout(cdr(msg) if through_cdr else msg, 40.0)
    np.testing.assert_array_equal(back.positions, layout.positions)  # float64: bit-exact
    np.testing.assert_array_equal(back.is_doa, layout.is_doa)
    assert all(np.array_equal(a, b) for a, b in zip(back.neighbours, layout.neighbours, strict=True))


def test_idsq_layout_reader_sorts_by_id_and_refuses_bad_clouds():
    from track_msgs_py.clouds import table_to_pointcloud2

    xy = np.array([[0.0, 0.0], [10.0, 0.0], [0.0, 10.0]])
    shuffled = table_to_pointcloud2(0.0, 'map', {'id': [2, 0, 1], 'x': xy[[2, 0, 1], 0], 'y': xy[[2, 0, 1], 1],
                                                 'type': [1, 0, 0]})
    back = pointcloud2_to_layout(shuffled, 40.0)
    np.testing.assert_array_equal(back.positions, xy)
    np.testing.assert_array_equal(back.is_doa, [False, False, True])
    for fields, reason in [({'id': [0, 1], 'x': [0, 1], 'y': [0, 1]}, 'no field.*type'),
                           ({'id': [0, 2], 'x': [0, 1], 'y': [0, 1], 'type': [0, 0]}, 'ids must be 0..1'),
                           ({'id': [0, 1], 'x': [0, 1], 'y': [0, 1], 'type': [0, 2]}, 'type must be 0')]:
        with pytest.raises(ValueError, match=reason):
            pointcloud2_to_layout(table_to_pointcloud2(0.0, 'map', fields), 40.0)
