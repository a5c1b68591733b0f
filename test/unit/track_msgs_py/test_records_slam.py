"""SLAM records: /slam/mode and /slam/events round-trip through their DiagnosticArray, with the keys, order
and texts the node has always written; the /slam/scan table round-trips through PointCloud2."""

from __future__ import annotations

import numpy as np
import pytest

from track_msgs_py.clouds import pointcloud2_to_table, table_to_pointcloud2
from track_msgs_py.diagnostics import diagnostic_array, diagnostic_status
from track_msgs_py.records import DIAG_OK, DIAG_WARN, RecordError, diagnostic_values
from track_msgs_py.records.slam import SlamEvent, SlamMode, SlamScan
from track_msgs_py.stamps import stamp_to_sec

MODE = SlamMode('PF', 120, 960, 23, 2, 4, 7, 1, 0, 3)


def test_mode_round_trip_and_layout():
    msg = MODE.to_msg(12.5, 'slam')
    assert stamp_to_sec(msg.header.stamp) == 12.5 and len(msg.status) == 1
    st = msg.status[0]
    assert (st.name, st.level, st.message) == ('slam/mode', bytes([DIAG_OK]), 'PF')
    assert list(diagnostic_values(st).items()) == [
        ('mode', 'PF'), ('scans', '120'), ('inputs', '960'), ('landmarks', '23'), ('pf_switches', '2'),
        ('pf_scans', '4'), ('dropped_observations', '7'), ('refused_messages', '1'), ('bad_inputs', '0'),
        ('bad_scans', '3')]
    assert SlamMode.from_msg(msg) == MODE


def test_mode_equals_the_hand_built_message_of_the_old_node():
    values = {'mode': 'CEKF', 'scans': 3, 'inputs': 30, 'landmarks': 5, 'pf_switches': 0, 'pf_scans': 0,
              'dropped_observations': 0, 'refused_messages': 2, 'bad_inputs': 1, 'bad_scans': 0}
    old = diagnostic_array(1.0, [diagnostic_status('slam/mode', DIAG_OK, 'CEKF', values)])
    assert SlamMode(**values).to_msg(1.0, 'slam') == old


@pytest.mark.parametrize(('kind', 'level', 'text'), [
    ('to_pf', DIAG_WARN, 'CEKF -> PF'), ('to_cekf', DIAG_OK, 'PF -> CEKF'),
    ('pf_timeout', DIAG_WARN, 'PF -> CEKF (timeout)')])
def test_event_round_trip_level_and_text(kind, level, text):
    ev = SlamEvent(kind, 41.123456789, 5, 1.0 / 3.0, -2.5, 3.0)
    msg = ev.to_msg('slam')
    st = msg.status[0]
    assert (st.name, st.level, st.message) == ('slam/mode_switch', bytes([level]), text)
    assert stamp_to_sec(msg.header.stamp) == pytest.approx(41.123456789, abs=1e-9)
    assert diagnostic_values(st) == {'event': kind, 't': '41.123456789', 'pf_scans': '5',
                                     'x': str(1.0 / 3.0), 'y': '-2.5', 'yaw': '3.0'}
    assert SlamEvent.from_msg(msg) == ev  # floats exactly


def test_bad_records_are_one_line():
    st = MODE.to_status('slam/mode')
    st.values = [kv for kv in st.values if kv.key != 'landmarks']
    with pytest.raises(RecordError, match="slam mode: missing key 'landmarks'"):
        SlamMode.from_status(st)
    with pytest.raises(RecordError, match='expected one status, got 0'):
        SlamEvent.from_msg(diagnostic_array(0.0, []))


def test_scan_round_trip_through_pointcloud2():
    # float32-exact values: the table travels as float32
    scan = SlamScan(2.25, np.array([10.5, 20.25, 3.0]), np.array([0.5, 1.5, 3.140625]), np.array([0.25, 0.0, 1.0]),
                    {'landmark': np.array([3.0, 7.0, 1.0])})
    msg = scan.to_msg()
    assert [f.name for f in msg.fields] == ['x', 'y', 'z', 'range', 'bearing', 'diameter', 'landmark']
    assert [f.offset for f in msg.fields[:3]] == [0, 4, 8]
    assert msg.header.frame_id == 'laser' and msg.width == 3
    table = pointcloud2_to_table(msg)  # the detections in the laser frame (x ahead, y left), float32
    np.testing.assert_allclose(table['x'], scan.range * np.sin(scan.bearing), rtol=1e-6)
    np.testing.assert_allclose(table['y'], -scan.range * np.cos(scan.bearing), rtol=1e-6, atol=1e-5)
    assert not table['z'].any()
    back = SlamScan.from_msg(msg)
    assert back.t == 2.25 and back.frame_id == 'laser' and list(back.extra) == ['landmark']
    for a, b in ((back.range, scan.range), (back.bearing, scan.bearing), (back.diameter, scan.diameter),
                 (back.extra['landmark'], scan.extra['landmark'])):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(back.z, np.stack([scan.range, scan.bearing], axis=1))


def test_scan_without_diameter_reads_zero_and_empty_scans_round_trip():
    msg = table_to_pointcloud2(1.0, 'laser', {'range': np.array([4.0]), 'bearing': np.array([1.0])})
    np.testing.assert_array_equal(SlamScan.from_msg(msg).diameter, [0.0])
    empty = SlamScan(3.0, np.zeros(0), np.zeros(0), np.zeros(0)).to_msg()
    back = SlamScan.from_msg(empty)
    assert empty.width == 0 and back.range.shape == (0,) and back.z.shape == (0, 2)


def test_scan_without_range_or_bearing_is_refused_in_one_line():
    msg = table_to_pointcloud2(1.0, 'laser', {'r': np.ones(2)})
    with pytest.raises(RecordError) as exc:
        SlamScan.from_msg(msg)
    text = str(exc.value)
    assert '\n' not in text and 'missing range, bearing' in text and 'fields: r' in text
