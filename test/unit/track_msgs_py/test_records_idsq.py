"""IDSQ records: the ack/nack reply and the /idsq/leader events round-trip, and are written exactly as
the sensors wrote them by hand before the records existed (same keys, order, words and levels); the
sensor layout and the handoff bytes round-trip exactly, also through CDR (rclpy.serialization)."""

from __future__ import annotations

import numpy as np
import pytest
from rclpy.serialization import deserialize_message, serialize_message

from track_msgs_py.diagnostics import diagnostic_status
from track_msgs_py.records import DIAG_OK, DIAG_WARN, RecordError
from track_msgs_py.records.idsq import (
    HANDOFF_LABEL,
    LAYOUT_FIELDS,
    IdsqAck,
    IdsqLeaderEvent,
    handoff_to_uint8_array,
    layout_to_pointcloud2,
    pointcloud2_to_layout,
    uint8_array_to_handoff,
)


def cdr(msg):
    """Serialise and deserialise: what a subscriber or a bag reader gets."""
    return deserialize_message(serialize_message(msg), type(msg))


def _same(a, b) -> None:
    assert (a.level, a.name, a.message, a.hardware_id) == (b.level, b.name, b.message, b.hardware_id)
    assert [(kv.key, kv.value) for kv in a.values] == [(kv.key, kv.value) for kv in b.values]


def test_ack_and_nack_are_the_old_layout_and_round_trip():
    _same(IdsqAck.reply(4, 2, 7, None), diagnostic_status(
        'sensor_7', DIAG_OK, 'ack', {'step': 4, 'sender': 2, 'receiver': 7, 'result': 'ack'}))
    nack = IdsqAck.reply(4, 2, 7, 'wrong grid')
    _same(nack, diagnostic_status('sensor_7', DIAG_WARN, 'refused: wrong grid',
                                  {'step': 4, 'sender': 2, 'receiver': 7, 'result': 'nack'}))
    back = IdsqAck.from_status(nack)
    assert back == IdsqAck(4, 2, 7, 'nack') and not back.accepted and IdsqAck(1, 2, 3, 'ack').accepted


@pytest.mark.parametrize('values', [{'step': '1', 'sender': '2', 'receiver': '3'},
                                    {'step': 'x', 'sender': '2', 'receiver': '3', 'result': 'ack'}])
def test_a_malformed_ack_is_one_line(values):
    with pytest.raises(RecordError) as exc:
        IdsqAck.from_values(values)
    assert 'idsq ack' in str(exc.value) and '\n' not in str(exc.value)


def test_step_event_is_the_old_layout_and_round_trips():
    z, spread, scores = np.float64(12.345678901), np.float64(123.25), np.array([0.123456789, 2.0, 1e-7])
    ev = IdsqLeaderEvent('step', 5, 3, 9, previous=-1, z=float(z), updated=True, belief_size=np.int64(42),
                         spread_m2=float(spread), candidates=(9, 4, 1), mi_bits=tuple(scores.tolist()),
                         handoff_bytes=200)
    old = diagnostic_status('sensor_3', DIAG_OK, 'step 5: sensor 3 -> sensor 9', {
        'event': 'step', 'step': 5, 'leader': 3, 'next': 9, 'previous': -1, 'z': z, 'updated': np.True_,
        'belief_size': np.int64(42), 'spread_m2': spread, 'candidates': '9 4 1',
        'mi_bits': ' '.join(f'{s:.6g}' for s in scores), 'handoff_bytes': 200})
    st = ev.to_status()
    _same(st, old)
    back = IdsqLeaderEvent.from_status(st)
    assert back.updated is True and back.candidates == (9, 4, 1) and back.mi_bits == (0.123457, 2.0, 1e-7)
    assert back == IdsqLeaderEvent(**{**ev.__dict__, 'mi_bits': (0.123457, 2.0, 1e-7), 'belief_size': 42})


def test_reselect_and_self_events_are_the_old_layout():
    _same(IdsqLeaderEvent('reselect', 7, 2, 5, failed=4, reason='timeout', handoff_bytes=96).to_status(),
          diagnostic_status('sensor_2', DIAG_WARN, 'reselect 7: sensor 2 -> sensor 5', {
              'event': 'reselect', 'step': 7, 'leader': 2, 'next': 5, 'failed': 4, 'reason': 'timeout',
              'handoff_bytes': 96}))
    st = IdsqLeaderEvent('self', 7, 2, 2, tried=(4, 5)).to_status()
    _same(st, diagnostic_status('sensor_2', DIAG_WARN, 'self 7: sensor 2 -> sensor 2', {
        'event': 'self', 'step': 7, 'leader': 2, 'next': 2, 'tried': '4 5', 'handoff_bytes': 0}))
    assert IdsqLeaderEvent.from_status(st) == IdsqLeaderEvent('self', 7, 2, 2, tried=(4, 5))
    with pytest.raises(RecordError, match='event'):
        IdsqLeaderEvent.from_values({'event': 'lead', 'step': '1', 'leader': '2', 'next': '3'})


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


@pytest.mark.parametrize('through_cdr', [False, True])
def test_idsq_handoff_message_round_trip(through_cdr):
    from std_msgs.msg import UInt8MultiArray

    from track_core.idsq import GridSpec, Handoff, encode_handoff, receive_handoff

    grid = GridSpec.for_field()
    payload = encode_handoff(Handoff(4, 1, 2, grid, np.array([3, 8, 40]), np.array([0.5, 0.25, 0.25])))
    msg = handoff_to_uint8_array(payload)
    assert isinstance(msg, UInt8MultiArray)
    assert [(d.label, d.size, d.stride) for d in msg.layout.dim] == [(HANDOFF_LABEL, len(payload), len(payload))]
    data = uint8_array_to_handoff(cdr(msg) if through_cdr else msg)
    assert isinstance(data, bytes) and data == payload
    h, why = receive_handoff(data, grid, receiver=2)
    assert why is None and (h.step, h.sender, h.receiver) == (4, 1, 2)
    assert uint8_array_to_handoff(handoff_to_uint8_array(b'')) == b''
