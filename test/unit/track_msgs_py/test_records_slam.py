"""SLAM records: /slam/mode and /slam/events round-trip through their typed messages (SlamStatus,
SlamEvent); the /slam/scan table round-trips through PointCloud2."""

from __future__ import annotations

import numpy as np
import pytest
from rclpy.serialization import deserialize_message, serialize_message

from track_msgs import msg as tm
from track_msgs_py.clouds import pointcloud2_to_table, table_to_pointcloud2
from track_msgs_py.records import RecordError
from track_msgs_py.records.slam import SlamEvent, SlamMode, SlamScan
from track_msgs_py.stamps import stamp_to_sec

MODE = SlamMode('PF', 120, 960, 23, 2, 4, 7, 1, 0, 3)


def test_mode_round_trip_through_cdr():
    msg = deserialize_message(serialize_message(MODE.to_msg(12.5)), tm.SlamStatus)
    assert stamp_to_sec(msg.header.stamp) == 12.5 and msg.mode == tm.SlamStatus.PF and msg.landmarks == 23
    assert SlamMode.from_msg(msg) == MODE


@pytest.mark.parametrize(('kind', 'code', 'text'), [
    ('to_pf', tm.SlamEvent.TO_PF, 'CEKF -> PF'), ('to_cekf', tm.SlamEvent.TO_CEKF, 'PF -> CEKF'),
    ('pf_timeout', tm.SlamEvent.PF_TIMEOUT, 'PF -> CEKF (timeout)')])
def test_event_round_trip_code_and_text(kind, code, text):
    ev = SlamEvent(kind, 41.123456789, 5, 1.0 / 3.0, -2.5, 3.0)
    msg = deserialize_message(serialize_message(ev.to_msg('map')), tm.SlamEvent)
    assert msg.event == code and msg.header.frame_id == 'map' and ev.text == text
    assert stamp_to_sec(msg.header.stamp) == pytest.approx(41.123456789, abs=1e-9)
    back = SlamEvent.from_msg(msg)
    assert (back.event, back.pf_scans, back.x, back.y, back.yaw) == (kind, 5, 1.0 / 3.0, -2.5, 3.0)  # floats exactly


def test_bad_records_are_one_line():
    msg = MODE.to_msg(1.0)
    msg.mode = 7
    with pytest.raises(RecordError, match='slam mode: code 7'):
        SlamMode.from_msg(msg)
    with pytest.raises(RecordError, match="'to_nowhere' is not one of"):
        SlamEvent('to_nowhere', 1.0, 0, 0.0, 0.0, 0.0).to_msg()


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
