"""Landmark detections, the landmark map, laser scans and planar odometry (track_msgs_py.records.landmarks)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from rclpy.serialization import deserialize_message, serialize_message
from sensor_msgs.msg import LaserScan

from track_core.slam.landmarks import Detections
from track_msgs_py.records import RecordError
from track_msgs_py.records.landmarks import (
    LandmarkDetections,
    LandmarkMap,
    LaserScanData,
    PlanarOdometry,
    planar_odometry_msg,
)
from track_msgs_py.stamps import stamped_header


def _detections(n=3) -> LandmarkDetections:
    cov = np.tile(np.diag([0.01, 1e-4, 0.004]), (n, 1, 1))
    return LandmarkDetections.from_detections(12.5, 'laser', Detections(np.arange(1.0, n + 1), np.linspace(-1, 1, n),
                                                                          np.full(n, 0.3), cov))


def test_detections_round_trip_through_the_wire():
    rec = _detections()
    msg = deserialize_message(serialize_message(rec.to_msg()), LandmarkDetections.msg_type())
    back = LandmarkDetections.from_msg(msg)
    assert back.t == 12.5 and back.frame_id == 'laser' and back.id.tolist() == [-1, -1, -1]
    for name in ('range', 'bearing', 'diameter', 'covariance'):
        np.testing.assert_array_equal(getattr(back, name), getattr(rec, name))
    msg.id = []                                        # no ids at all: every identity unknown
    assert LandmarkDetections.from_msg(msg).id.tolist() == [-1, -1, -1]


@pytest.mark.parametrize(('field', 'value', 'words'), [
    ('bearing', [0.0, 1.0], 'bearing has 2'), ('covariance', [0.0] * 26, 'need 9 per detection'),
    ('id', [1, 2], 'id has 2'), ('range', [1.0] * 20, 'more than the cap')])
def test_detections_that_cannot_be_read_are_refused_with_one_line(field, value, words):
    msg = _detections().to_msg()
    setattr(msg, field, value)
    with pytest.raises(RecordError, match=words):
        LandmarkDetections.from_msg(msg, max_size=10)


def test_detections_with_a_covariance_that_is_not_one_are_refused():
    msg = _detections(1).to_msg()
    msg.covariance = [1.0, 2.0, 0, 0, 1.0, 0, 0, 0, 1.0]
    with pytest.raises(RecordError, match='not symmetric'):
        LandmarkDetections.from_msg(msg)
    msg.covariance = [-1.0, 0, 0, 0, 1.0, 0, 0, 0, 1.0]
    with pytest.raises(RecordError, match='positive semi-definite'):
        LandmarkDetections.from_msg(msg)


def test_landmark_map_round_trip():
    covs = np.array([[[0.1, 0.01], [0.01, 0.2]], [[0.3, 0.0], [0.0, 0.4]]])
    rec = LandmarkMap(3.0, 'map', np.arange(2), np.array([[1.0, 2.0], [-3.0, 4.0]]), covs)
    msg = deserialize_message(serialize_message(rec.to_msg()), LandmarkMap.msg_type())
    back = LandmarkMap.from_msg(msg)
    np.testing.assert_array_equal(back.xy, rec.xy)
    np.testing.assert_array_equal(back.covariance, covs)
    msg.x = [1.0]
    with pytest.raises(RecordError, match='column lengths'):
        LandmarkMap.from_msg(msg)


def test_laser_scan_checks():
    msg = LaserScan(header=stamped_header(1.0, 'laser'), angle_min=-math.pi, angle_increment=math.pi / 180,
                    range_min=0.1, range_max=30.0, ranges=[1.0] * 360)
    scan = LaserScanData.from_msg(msg)
    assert scan.ranges.size == 360 and scan.frame_id == 'laser'
    with pytest.raises(RecordError, match='cap'):
        LaserScanData.from_msg(msg, max_beams=100)
    for bad in ({'angle_increment': 0.0}, {'angle_increment': math.nan}, {'angle_increment': 0.1},
                {'range_min': 5.0, 'range_max': 1.0}):
        m = LaserScan(header=msg.header, angle_min=msg.angle_min, angle_increment=msg.angle_increment,
                      range_min=msg.range_min, range_max=msg.range_max, ranges=msg.ranges)
        for k, v in bad.items():
            setattr(m, k, v)
        with pytest.raises(RecordError):
            LaserScanData.from_msg(m)


def test_planar_odometry_reads_rep105_and_its_twist_covariance():
    cov = np.array([[0.01, 0.001], [0.001, 0.004]])
    msg = planar_odometry_msg(5.0, np.array([1.0, 2.0, 2.5]), 0.7, -0.2, cov, 'odom', 'base_link')
    odo = PlanarOdometry.from_msg(msg)
    assert (odo.frame_id, odo.child_frame_id, odo.v, odo.w) == ('odom', 'base_link', 0.7, -0.2)
    np.testing.assert_allclose(odo.pose, [1.0, 2.0, 2.5])
    np.testing.assert_array_equal(odo.cov, cov)
    assert PlanarOdometry.from_msg(planar_odometry_msg(5.0, np.zeros(3), 0.0, 0.0, None, 'odom', 'b')).cov is None
    msg.twist.covariance[35] = -1.0
    with pytest.raises(RecordError, match='not a symmetric PSD'):
        PlanarOdometry.from_msg(msg)
