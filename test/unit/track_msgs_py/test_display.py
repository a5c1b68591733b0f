"""Display conventions (issue 19): every cloud we publish has float32 x, y, z first, every covariance is planar.

Each check is shown to fail on the layout we published before issue 19 (the same builders as then,
written out here) and to pass on what the converters and records write now.
"""

from __future__ import annotations

import numpy as np
import pytest
from geometry_msgs.msg import PoseWithCovarianceStamped
from nav_msgs.msg import Odometry
from sensor_msgs.msg import PointCloud2, PointField

from track_msgs_py.clouds import scan_to_pointcloud2, table_to_pointcloud2
from track_msgs_py.display import cloud_xyz_problem, display_problems, planar_covariance_problem
from track_msgs_py.odometry import cv_state_to_odometry, pose_to_odometry, position_to_pose_cov

X = np.array([1.0, 0.5, -2.0, 0.25])
P = np.diag([4.0, 1.0, 9.0, 0.5])
ONES = np.ones(3)


def _old_layout() -> PointCloud2:
    """/idsq/layout before issue 19: FLOAT64 id, x, y, type at offsets 0, 8, 16, 24."""
    names = ('id', 'x', 'y', 'type')
    table = np.zeros(3, dtype=[(n, '<f8') for n in names])
    return PointCloud2(height=1, width=3, point_step=32, row_step=96, data=table.tobytes(),
                       fields=[PointField(name=n, offset=8 * i, datatype=PointField.FLOAT64, count=1)
                               for i, n in enumerate(names)])


OLD_CLOUDS = {
    'slam scan': table_to_pointcloud2(1.0, 'laser', {'range': ONES, 'bearing': ONES, 'diameter': ONES}),
    'rfid phase': table_to_pointcloud2(1.0, 'rfid_reader', {'t': ONES, 'phase': ONES, 'rssi': ONES,
                                                            'carrier_mhz': ONES}),
    'idsq belief (no z)': table_to_pointcloud2(1.0, 'map', {'x': ONES, 'y': ONES, 'p': ONES}),
    'idsq layout (float64, no z)': _old_layout(),
}


def _old_covariance(msg):
    """The covariance of before issue 19: 1e6 on every diagonal entry but the x/y block (and SLAM's yaw)."""
    for holder in ('pose', 'twist'):
        inner = getattr(msg, holder, None)
        if inner is not None:
            c = np.asarray(inner.covariance).reshape(6, 6).copy()
            c[2, 2] = c[3, 3] = c[4, 4] = 1e6
            inner.covariance = c.reshape(36)
    return msg


@pytest.mark.parametrize('name', list(OLD_CLOUDS))
def test_every_old_cloud_layout_fails_the_cloud_check(name):
    reason = cloud_xyz_problem(OLD_CLOUDS[name])
    assert reason is not None and '\n' not in reason
    assert display_problems(OLD_CLOUDS[name]) == [reason]


def test_new_clouds_pass_and_a_wrong_type_or_offset_fails():
    from track_core.idsq import SensorLayout
    from track_core.rfid.signal import PhaseStream
    from track_msgs_py.records.idsq import IdsqBelief, layout_to_pointcloud2
    from track_msgs_py.records.rfid import RfidPhase

    stream = PhaseStream(ONES, ONES, ONES, xy=np.zeros((3, 2)))
    new = [scan_to_pointcloud2(1.0, np.ones((3, 2))), RfidPhase.from_stream(1.0, stream, 0.0, 866e6, ONES).to_msg(),
           IdsqBelief(1.0, np.zeros((3, 2)), ONES).to_msg(),
           layout_to_pointcloud2(0.0, SensorLayout(np.array([[0.0, 0.0], [30.0, 0.0], [0.0, 30.0]]),
                                                   np.array([False, True, False]), 40.0))]
    assert [cloud_xyz_problem(m) for m in new] == [None] * 4
    f64 = table_to_pointcloud2(0.0, 'map', {'x': ONES, 'y': ONES, 'z': ONES})
    f64.fields[2].datatype = PointField.FLOAT64
    assert 'field z: datatype 8' in cloud_xyz_problem(f64)
    shifted = table_to_pointcloud2(0.0, 'map', {'p': ONES, 'x': ONES, 'y': ONES, 'z': ONES})
    assert cloud_xyz_problem(shifted) == 'field x: offset 4 (need 0)'


def _ours() -> dict[str, object]:
    return {'cv odometry': cv_state_to_odometry(1.0, X, P, 'map', 't'),
            'truth odometry': cv_state_to_odometry(1.0, X, np.zeros((4, 4)), 'map', 't'),
            'position report': position_to_pose_cov(1.0, X[[0, 2]], np.diag([4.0, 9.0])),
            'slam pose': pose_to_odometry(1.0, np.array([1.0, 2.0, 0.5]), np.diag([0.1, 0.2, 0.01]))}


@pytest.mark.parametrize('name', list(_ours()))
def test_our_covariances_pass_and_the_old_1e6_fails(name):
    msg = _ours()[name]
    assert display_problems(msg) == []
    old = display_problems(_old_covariance(msg))
    assert old and all('z variance 1e+06 is larger than the x/y variances' in r for r in old)
    # Odometry: the pose and the twist, but the SLAM twist was all 1e6 (z not larger than its x/y 1e6)
    assert len(old) == (2 if isinstance(msg, Odometry) and name != 'slam pose' else 1)


def test_planar_covariance_problem_edges():
    c = np.zeros(36)
    assert planar_covariance_problem('c', c) is None  # truth: all zero
    c[0], c[7], c[14] = 4.0, 1.0, 2.0
    assert 'z variance 2 is larger' in planar_covariance_problem('pose.covariance', c)
    c[14] = np.nan
    assert planar_covariance_problem('c', c) is not None
    assert 'expected 36' in planar_covariance_problem('c', np.zeros(9))
    assert display_problems(PoseWithCovarianceStamped()) == []


def test_display_twins_keep_header_pose_and_covariance():
    """Foxglove's 3D panel draws neither Odometry nor PointStamped: their twins carry what it needs."""
    from geometry_msgs.msg import PointStamped, PoseStamped

    from track_msgs_py.display import FOXGLOVE_3D_TYPES, display_twin
    from track_msgs_py.topics import DISPLAY_TWINS, TOPICS, TWIN_TYPES
    from track_msgs_py.topics import display_twin as twin_topic

    odom = cv_state_to_odometry(12.5, X, P, child_frame_id='sonar_track')
    twin = display_twin(odom)
    assert isinstance(twin, PoseWithCovarianceStamped)
    assert twin.header == odom.header and twin.pose == odom.pose  # the 2σ ellipse comes with the covariance
    assert list(twin.pose.covariance) == list(odom.pose.covariance) and twin.pose.covariance[0] == 4.0
    point = PointStamped()
    point.header.frame_id, point.point.x, point.point.y = 'rfid_user', 1.5, -0.5
    pose = display_twin(point)
    assert isinstance(pose, PoseStamped) and pose.header.frame_id == 'rfid_user'
    assert (pose.pose.position.x, pose.pose.position.y, pose.pose.orientation.w) == (1.5, -0.5, 1.0)
    for topic in DISPLAY_TWINS:  # every twin is in the table, of a type the panel draws, with the original's QoS
        spec = TOPICS[twin_topic(topic)]
        assert spec.msgtype == TWIN_TYPES[TOPICS[topic].msgtype] and spec.msgtype in FOXGLOVE_3D_TYPES
        assert spec.qos == TOPICS[topic].qos
    assert twin_topic('/sonar/estimate') == '/sonar/estimate/pose' and twin_topic('a/b') == 'a/b/pose'
