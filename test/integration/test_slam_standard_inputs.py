"""``slam`` and ``landmark_extractor`` on a robot as a new user has one (standard inputs, REP-105 outputs).

The test is the user's script: a differential-drive robot drives a circle in a walled yard with a few
poles. Its "driver" publishes what real drivers do: ``nav_msgs/Odometry`` on ``/odom`` (pose of
base_link in odom from a biased, noisy wheel odometry, twist with its covariance) together with
odom → base_link on ``/tf``, and a 360° ``sensor_msgs/LaserScan`` on ``/scan`` (ray-cast from the
true pose, laser 0.2 m ahead of base_link). ``landmark_extractor`` turns the scans into landmark
detections and ``slam`` (``input_model: odometry``, ``observations: detections``, profile
``generic``) must give map → odom on /tf, the pose with covariance and the landmark map, with
base_link keeping its one parent (odom).

The Victoria Park run converted to those inputs (``track-dataset victoria-park --standard``) replayed into
``slam`` gives the path of the ACFR encoder-and-steering input.
"""

from __future__ import annotations

import numpy as np
import pytest
from geometry_msgs.msg import PoseWithCovarianceStamped
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import LaserScan
from tf2_msgs.msg import TFMessage

from track_core.filters.poses import compose, relative_pose, unicycle_arc
from track_core.slam.sim import raycast_scan
from track_msgs_py.odometry import odometry_to_pose
from track_msgs_py.qos import STATIC_QOS, qos_for_topic
from track_msgs_py.records.landmarks import LandmarkDetections, LandmarkMap, planar_odometry_msg
from track_msgs_py.stamps import stamped_header
from track_msgs_py.tf import TF, TF_QOS, planar_transform
from track_msgs_py.topics import (
    SLAM_LANDMARK_MAP,
    SLAM_LANDMARKS,
    SLAM_LASER_SCAN,
    SLAM_ODOM,
    SLAM_POSE,
    display_twin,
)
from track_nodes.slam.landmark_extractor import LandmarkExtractorNode
from track_nodes.slam.slam import SlamNode

WALLS = np.array([[[-20, -15], [20, -15]], [[20, -15], [20, 15]], [[20, 15], [-20, 15]], [[-20, 15], [-20, -15]],
                  [[-20, 5], [-12, 5]]], float)
POLES = np.array([[-6.0, -3.0], [-3.0, 6.0], [4.0, 8.0], [8.0, 1.0], [5.0, -7.0], [-2.0, -9.0], [12.0, -4.0],
                  [-10.0, 1.0]])
RADII = np.full(len(POLES), 0.12)
LASER = np.array([0.2, 0.0, 0.0])                 # the laser in base_link
ANGLES = np.linspace(-np.pi, np.pi, 720, endpoint=False)
T0, DT_ODOM, SCAN_EVERY, N_STEPS = 1000.0, 0.05, 4, 600   # 30 s: odometry at 20 Hz, scans at 5 Hz
V, W = 1.0, 0.1                                    # a circle of 10 m radius about (0, 10) ... from (0, 0)
SIG_V, SIG_W, BIAS_W = 0.05, 0.02, 0.005          # the wheel odometry: noise and a yaw-rate bias


def _drive(seed: int = 0):
    """True poses and the driver's odometry (pose in odom, measured twist) every DT_ODOM."""
    rng = np.random.default_rng(seed)
    truth, odom = [np.array([0.0, -5.0, 0.0])], [np.zeros(3)]
    meas = []
    for _ in range(N_STEPS):
        v, w = V + SIG_V * rng.standard_normal(), W + BIAS_W + SIG_W * rng.standard_normal()
        meas.append((v, w))
        truth.append(unicycle_arc(truth[-1], V, W, DT_ODOM))
        odom.append(unicycle_arc(odom[-1], v, w, DT_ODOM))
    meas.append(meas[-1])
    return np.array(truth), np.array(odom), np.array(meas)


def _scan_msg(t: float, pose: np.ndarray, rng) -> LaserScan:
    laser = compose(pose, LASER)
    r = raycast_scan(laser, ANGLES, WALLS, POLES, RADII, 30.0, 0.01, rng)
    msg = LaserScan(header=stamped_header(t, 'laser'), angle_min=float(ANGLES[0]),
                    angle_max=float(ANGLES[-1]), angle_increment=float(ANGLES[1] - ANGLES[0]), range_min=0.05,
                    range_max=30.0)
    msg.ranges = r.astype(np.float32).tolist()
    return msg


def _play(ros, extractor, pub_odom, pub_scan, pub_tf, truth, odom, meas) -> int:
    """The driver: odometry and odom -> base_link every DT_ODOM, a scan between two of them every SCAN_EVERY
    (each waited for: the scan topic is best effort); → the number of scans."""
    cov = np.diag([SIG_V**2, SIG_W**2])
    rng = np.random.default_rng(1)
    n_scans = 0
    for k in range(N_STEPS + 1):
        t = T0 + k * DT_ODOM
        pub_odom.publish(planar_odometry_msg(t, odom[k], *meas[k], cov, 'odom', 'base_link'))
        pub_tf.publish(TFMessage(transforms=[planar_transform(t, 'odom', 'base_link', *odom[k])]))
        if k % SCAN_EVERY == 2:   # between two odometry messages
            pub_scan.publish(_scan_msg(t + 0.5 * DT_ODOM, unicycle_arc(truth[k], V, W, 0.5 * DT_ODOM), rng))
            n_scans += 1
            assert ros.spin_until(lambda n=n_scans: extractor.n_scans == n), f'extractor at {extractor.n_scans}'
    return n_scans


@pytest.mark.parametrize('motion', ['increments', 'twist'])
def test_new_user_robot_gets_map_to_odom_pose_and_landmark_map(ros, motion):
    slam = ros.add(SlamNode(context=ros.context, parameter_overrides=[
        Parameter('profile', value='generic'), Parameter('input_model', value='odometry'),
        Parameter('odometry_motion', value=motion), Parameter('observations', value='detections'),
        Parameter('laser_pose', value=LASER.tolist()), Parameter('pose0', value=[0.0, 0.0, 0.0]),
        Parameter('map_period', value=0.0)]))
    extractor = ros.add(LandmarkExtractorNode(context=ros.context))
    user = ros.add(Node('robot_driver', context=ros.context))
    pub_odom = user.create_publisher(Odometry, 'odom', qos_for_topic(SLAM_ODOM))
    pub_scan = user.create_publisher(LaserScan, 'scan', qos_for_topic(SLAM_LASER_SCAN))
    pub_tf = user.create_publisher(TFMessage, TF, TF_QOS)
    got: dict[str, list] = {'tf': [], 'pose': [], 'map': []}
    user.create_subscription(TFMessage, TF, got['tf'].append, TF_QOS)
    user.create_subscription(PoseWithCovarianceStamped, display_twin(SLAM_POSE), got['pose'].append,
                             QoSProfile(depth=10_000, reliability=ReliabilityPolicy.RELIABLE))
    user.create_subscription(LandmarkMap.msg_type(), SLAM_LANDMARK_MAP, got['map'].append, STATIC_QOS)
    assert ros.spin_until(lambda: pub_odom.get_subscription_count() > 0 and pub_scan.get_subscription_count() > 0
                          and slam.sub_scan.get_publisher_count() > 0)

    truth, odom, meas = _drive()
    n_scans = _play(ros, extractor, pub_odom, pub_scan, pub_tf, truth, odom, meas)
    assert ros.spin_until(lambda: slam.n_scans == n_scans and not len(slam.merger), timeout=30), \
        f'slam processed {slam.n_scans}/{n_scans} scans'
    assert ros.spin_until(lambda: len(got['pose']) == n_scans and got['map'], timeout=10)
    assert slam.n_refused == 0 and slam.n_bad_inputs == 0 and slam.n_bad_scans == 0
    assert extractor.n_detections >= 3 * n_scans                      # a few poles in every scan

    # base_link keeps one parent: the driver's odom; slam broadcasts map -> odom and nothing else
    parents = {(tr.header.frame_id, tr.child_frame_id) for m in got['tf'] for tr in m.transforms}
    assert parents == {('odom', 'base_link'), ('map', 'odom')}, parents
    # the pose with covariance of base_link in map, near the truth (the odometry alone drifts farther)
    last = got['pose'][-1]
    assert last.header.frame_id == 'map'
    t_last = T0 + (n_scans - 1) * SCAN_EVERY * DT_ODOM + 2.5 * DT_ODOM
    k_last = round((t_last - T0 - 0.5 * DT_ODOM) / DT_ODOM)
    true_last = unicycle_arc(truth[k_last], V, W, 0.5 * DT_ODOM)
    est = np.array([last.pose.pose.position.x, last.pose.pose.position.y])
    odo_err = np.hypot(*(unicycle_arc(odom[k_last], *meas[k_last], 0.5 * DT_ODOM)[:2]
                         - (true_last[:2] - truth[0][:2])))
    # the map frame is the start pose (pose0 = 0): compare in that frame
    true_in_map = relative_pose(truth[0], true_last)
    err = np.hypot(*(est - true_in_map[:2]))
    cov_xy = np.asarray(last.pose.covariance).reshape(6, 6)[:2, :2]
    assert np.all(np.linalg.eigvalsh(cov_xy) > 0)
    print(f'{motion}: final error {err:.3f} m (odometry alone {odo_err:.3f} m), {len(got["map"][-1].x)} landmarks')
    assert err < 0.5 and err < odo_err / 3
    # map -> odom composed with the driver's odom -> base_link is the published pose
    mo = next(tr for m in reversed(got['tf']) for tr in m.transforms if tr.child_frame_id == 'odom')
    assert mo.header.stamp == last.header.stamp
    q = mo.transform.rotation
    mo_pose = np.array([mo.transform.translation.x, mo.transform.translation.y, 2 * np.arctan2(q.z, q.w)])
    _, pose_pub, _ = odometry_to_pose(Odometry(header=last.header, pose=last.pose))
    odom_at = slam.odom.pose_at(t_last)
    np.testing.assert_allclose(compose(mo_pose, odom_at)[:2], pose_pub[:2], atol=1e-6)
    # the landmark map: the poles seen, each within 0.3 m of the truth (in the map frame)
    lm = LandmarkMap.from_msg(got['map'][-1])
    true_lm = np.array([relative_pose(truth[0], np.array([*p, 0.0]))[:2] for p in POLES])
    d = np.linalg.norm(lm.xy[:, None] - true_lm[None], axis=2).min(axis=1)
    assert len(lm.xy) >= 5 and np.all(d < 0.3), d
    assert np.all(np.linalg.eigvalsh(lm.covariance) > 0)


# --- the Victoria Park run through the standard inputs --------------------------------------------------------



# --- hostile input on the standard inputs --------------------------------------------------------------------

def _filter_state(slam):
    import copy

    x, P = copy.deepcopy(slam.slam.cekf).mean_cov()
    return slam.slam.t, slam.slam.u.copy(), x, P, len(slam.odom)


def test_hostile_odometry_detections_and_scans_are_refused_without_a_change(ros):
    slam = ros.add(SlamNode(context=ros.context, parameter_overrides=[
        Parameter('profile', value='generic'), Parameter('input_model', value='odometry'),
        Parameter('observations', value='detections'), Parameter('max_detections', value=50),
        Parameter('warn_throttle', value=60.0)]))
    extractor = ros.add(LandmarkExtractorNode(context=ros.context, parameter_overrides=[
        Parameter('max_beams', value=1000)]))
    user = ros.add(Node('hostile', context=ros.context))
    pub_odom = user.create_publisher(Odometry, 'odom', qos_for_topic(SLAM_ODOM))
    pub_det = user.create_publisher(LandmarkDetections.msg_type(), 'slam/landmarks', qos_for_topic(SLAM_LANDMARKS))
    pub_scan = user.create_publisher(LaserScan, 'scan', qos_for_topic(SLAM_LASER_SCAN))
    assert ros.spin_until(lambda: pub_odom.get_subscription_count() > 0 and pub_det.get_subscription_count() > 0
                          and pub_scan.get_subscription_count() > 0)
    cov = np.diag([0.01, 0.001])
    pub_odom.publish(planar_odometry_msg(10.0, np.zeros(3), 1.0, 0.0, cov, 'odom', 'base_link'))
    pub_odom.publish(planar_odometry_msg(10.1, np.array([0.1, 0.0, 0.0]), 1.0, 0.0, cov, 'odom', 'base_link'))
    assert ros.spin_until(lambda: len(slam.odom) == 2)
    before = _filter_state(slam)
    bad_odom = [planar_odometry_msg(10.2, np.zeros(3), 1.0, 0.0, cov, 'map', 'base_link'),       # wrong frame
                planar_odometry_msg(10.2, np.zeros(3), 1.0, 0.0, cov, 'odom', 'laser'),          # wrong child
                planar_odometry_msg(10.2, np.array([np.nan, 0, 0]), 1.0, 0.0, cov, 'odom', 'base_link'),
                planar_odometry_msg(10.2, np.zeros(3), 1.0, 0.0, -cov, 'odom', 'base_link'),     # not a covariance
                planar_odometry_msg(9.0, np.zeros(3), 1.0, 0.0, cov, 'odom', 'base_link')]       # backwards
    for m in bad_odom:
        pub_odom.publish(m)
    assert ros.spin_until(lambda: slam.n_bad_inputs == len(bad_odom)), slam.n_bad_inputs
    det = LandmarkDetections(10.15, 'laser', np.ones(3), np.zeros(3), np.zeros(3), np.tile(np.eye(3), (3, 1, 1)),
                             np.full(3, -1, np.int32))
    wrong_frame = LandmarkDetections(10.15, 'camera', *[getattr(det, f) for f in ('range', 'bearing', 'diameter',
                                                                                  'covariance', 'id')])
    too_many = LandmarkDetections(10.15, 'laser', np.ones(60), np.zeros(60), np.zeros(60),
                                  np.tile(np.eye(3), (60, 1, 1)), np.full(60, -1, np.int32))
    short = det.to_msg()
    short.bearing = [0.0]
    for m in (wrong_frame.to_msg(), too_many.to_msg(), short):
        pub_det.publish(m)
    assert ros.spin_until(lambda: slam.n_bad_scans == 3), slam.n_bad_scans
    ros.spin_for(0.8)   # past flush_idle: anything buffered would be processed now
    after = _filter_state(slam)
    assert before[0] == after[0] and before[4] == after[4] and slam.n_scans == 0
    for a, b in zip(before[1:4], after[1:4], strict=True):
        np.testing.assert_array_equal(a, b)
    # the extractor: too many beams, a zero increment; nothing published, counted
    for kw in ({'angle_increment': 0.01, 'ranges': [1.0] * 2000}, {'angle_increment': 0.0, 'ranges': [1.0] * 10}):
        pub_scan.publish(LaserScan(header=stamped_header(10.2, 'laser'), angle_min=-1.0, range_min=0.1,
                                   range_max=30.0, **kw))
    assert ros.spin_until(lambda: extractor.refusals.total() == 2)
    assert extractor.n_scans == 0
