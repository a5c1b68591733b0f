"""IDSQ records: the ack/nack reply and the /idsq/leader events round-trip, and are written exactly as
the sensors wrote them by hand before the records existed (same keys, order, words and levels)."""

from __future__ import annotations

import numpy as np
import pytest

from track_msgs_py.convert import diagnostic_status
from track_msgs_py.records import DIAG_OK, DIAG_WARN, RecordError
from track_msgs_py.records.idsq import IdsqAck, IdsqLeaderEvent


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

    from track_msgs_py.convert import pointcloud2_to_table, table_to_pointcloud2
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
