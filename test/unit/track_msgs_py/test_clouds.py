"""Tables and points ⇄ PointCloud2 and the SLAM scan cloud, also through CDR (rclpy.serialization)."""

import math

import numpy as np
import pytest
from rclpy.serialization import deserialize_message, serialize_message
from sensor_msgs.msg import PointCloud2, PointField

from track_msgs_py.clouds import (
    cloud_columns,
    pointcloud2_to_table,
    points_to_pointcloud2,
    scan_points,
    table_to_pointcloud2,
)
from track_msgs_py.stamps import stamp_to_sec


def cdr(msg):
    """Serialise and deserialise: what a subscriber or a bag reader gets."""
    return deserialize_message(serialize_message(msg), type(msg))


@pytest.mark.parametrize('n', [0, 1, 7, 20_000])
@pytest.mark.parametrize('through_cdr', [False, True])
def test_pointcloud2_round_trip(n, through_cdr):
    rng = np.random.default_rng(n)
    table = {'x': rng.normal(size=n), 'y': rng.normal(size=n) * 1e3, 'phase': rng.uniform(-np.pi, np.pi, n),
             'weight': rng.uniform(size=n)}
    msg = table_to_pointcloud2(4.5, 'map', table)
    assert (msg.height, msg.width, msg.point_step, msg.row_step) == (1, n, 16, 16 * n)
    assert [(f.name, f.offset, f.datatype, f.count) for f in msg.fields] == [
        ('x', 0, PointField.FLOAT32, 1), ('y', 4, PointField.FLOAT32, 1),
        ('phase', 8, PointField.FLOAT32, 1), ('weight', 12, PointField.FLOAT32, 1)]
    assert len(msg.data) == 16 * n and msg.is_dense and not msg.is_bigendian
    if through_cdr:
        msg = cdr(msg)
    assert stamp_to_sec(msg.header.stamp) == 4.5
    back = pointcloud2_to_table(msg)
    assert list(back) == list(table)
    for name, col in table.items():
        assert back[name].dtype == np.float64 and back[name].shape == (n,)
        np.testing.assert_array_equal(back[name], col.astype(np.float32))


def test_points_come_first_as_float32_xyz():
    xy = np.array([[1.0, 2.0], [3.0, -4.0]])
    msg = cdr(points_to_pointcloud2(1.0, 'map', xy, {'p': np.array([0.25, 0.75])}))
    assert [(f.name, f.offset, f.datatype, f.count) for f in msg.fields] == [
        ('x', 0, PointField.FLOAT32, 1), ('y', 4, PointField.FLOAT32, 1), ('z', 8, PointField.FLOAT32, 1),
        ('p', 12, PointField.FLOAT32, 1)]
    table = pointcloud2_to_table(msg)
    np.testing.assert_array_equal(np.stack([table['x'], table['y']], 1), xy)
    np.testing.assert_array_equal(table['z'], [0.0, 0.0])
    assert list(cloud_columns(table)) == ['p']
    xyz = pointcloud2_to_table(points_to_pointcloud2(0.0, 'map', np.array([[1.0, 2.0, 3.0]]), {}))
    assert (xyz['x'][0], xyz['y'][0], xyz['z'][0]) == (1.0, 2.0, 3.0)
    with pytest.raises(ValueError, match='clash'):
        points_to_pointcloud2(0.0, 'map', xy, {'z': np.zeros(2)})
    with pytest.raises(ValueError, match='shape'):
        points_to_pointcloud2(0.0, 'map', np.zeros((2, 4)), {})


def test_scan_points_are_in_the_laser_frame_of_the_slam_pose():
    """x ahead, y left: the point put in map by the pose (x, y, φ) is where inverse_observe puts the landmark."""
    from track_core.slam.models import inverse_observe

    z = np.array([[10.0, math.pi / 2], [5.0, 0.0], [2.0, math.pi], [7.0, 0.4]])  # ahead, right, left, ...
    pts = scan_points(z)
    np.testing.assert_allclose(pts[:3], [[10.0, 0.0], [0.0, -5.0], [0.0, 2.0]], atol=1e-12)
    pose = np.array([3.0, -1.0, 0.7])
    c, s = math.cos(pose[2]), math.sin(pose[2])
    in_map = pose[:2] + pts @ np.array([[c, s], [-s, c]])
    np.testing.assert_allclose(in_map, inverse_observe(pose, z), atol=1e-12)


def test_pointcloud2_marks_non_finite_values_not_dense():
    msg = table_to_pointcloud2(0.0, 'map', {'a': np.array([1.0, np.nan]), 'b': np.array([0.0, 1.0])})
    assert not msg.is_dense
    assert np.isnan(pointcloud2_to_table(msg)['a'][1])


@pytest.mark.parametrize('fields', [{}, {'a': np.zeros(3), 'b': np.zeros(4)}, {'a': np.zeros((3, 2))}])
def test_pointcloud2_rejects_bad_tables(fields):
    with pytest.raises(ValueError, match='field'):
        table_to_pointcloud2(0.0, 'map', fields)


def test_pointcloud2_reads_foreign_layout():
    """Another producer: float64 + uint16 fields, big-endian, padded points and rows, height 2."""
    dtype = np.dtype({'names': ['range', 'id'], 'formats': ['>f8', '>u2'], 'offsets': [0, 8], 'itemsize': 12})
    pts = np.zeros((2, 3), dtype)
    pts['range'] = [[1.5, 2.5, 3.5], [4.5, 5.5, 6.5]]
    pts['id'] = [[1, 2, 3], [4, 5, 6]]
    rows = np.zeros((2, 40), np.uint8)  # row_step 40 > width * point_step = 36
    rows[:, :36] = pts.view(np.uint8).reshape(2, 36)
    msg = PointCloud2(height=2, width=3, is_bigendian=True, point_step=12, row_step=40,
                      fields=[PointField(name='range', offset=0, datatype=PointField.FLOAT64, count=1),
                              PointField(name='id', offset=8, datatype=PointField.UINT16, count=1)])
    msg.data = rows.tobytes()
    back = pointcloud2_to_table(cdr(msg))
    np.testing.assert_array_equal(back['range'], [1.5, 2.5, 3.5, 4.5, 5.5, 6.5])
    np.testing.assert_array_equal(back['id'], [1, 2, 3, 4, 5, 6])


def test_pointcloud2_too_short_data_is_an_error():
    msg = table_to_pointcloud2(0.0, 'map', {'a': np.arange(4.0)})
    msg.data = msg.data[:-4]
    with pytest.raises(ValueError, match='too short'):
        pointcloud2_to_table(msg)
