"""Victoria Park through the standard inputs, end to end: ``track-dataset victoria-park --standard``
(Odometry, odom -> base_link, landmark detections) replayed into the ``slam`` node gives the path of the
offline standard-input run, which equals the ACFR input's (``experiments.run_victoria`` and
``run_victoria_standard``, the references of this package)."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile, ReliabilityPolicy

from track_core.slam import victoria
from track_core.slam.models import VehicleParams
from track_experiments.slam.experiments import run_victoria, run_victoria_standard
from track_msgs_py.odometry import odometry_to_pose
from track_msgs_py.topics import SLAM_POSE
from track_nodes.bag.player import PlayerNode
from track_nodes.slam.slam import SlamNode

pytestmark = pytest.mark.integration

T_MAX = 40.0  # the stretch of the real run [s]


def test_victoria_park_as_odometry_and_detections_gives_the_acfr_path(ros, tmp_path, env_factory):
    """``track-dataset victoria-park --standard`` (Odometry, odom -> base_link, landmark detections) replayed into
    ``slam`` with the unicycle model: the laser path of the offline standard-input run, which equals the ACFR
    input's path (``experiments.run_victoria`` vs ``run_victoria_standard``, both here)."""
    if not (victoria.data_dir() / 'measurements.dat').is_file():
        pytest.skip(f'Victoria Park data not found at {victoria.data_dir()}')
    bag = tmp_path / 'vp_standard'
    proc = subprocess.run([sys.executable, '-m', 'track_nodes.bag.dataset', 'victoria-park', '--standard', '--out',
                           str(bag), '--t-max', str(T_MAX)], capture_output=True, text=True, timeout=120,
                          env=env_factory())
    assert proc.returncode == 0, proc.stderr
    a, b = VehicleParams().a, VehicleParams().b
    slam = ros.add(SlamNode(context=ros.context, parameter_overrides=[
        Parameter('input_model', value='odometry'), Parameter('observations', value='detections'),
        Parameter('laser_pose', value=[a, b, 0.0]), Parameter('pose0', value=[-a, -b, 0.0]),  # the laser at 0
        Parameter('pose_of', value='laser')]))
    poses = []
    user = ros.add(Node('vp_sink', context=ros.context))
    user.create_subscription(Odometry, SLAM_POSE, poses.append, QoSProfile(depth=100_000,
                                                                           reliability=ReliabilityPolicy.RELIABLE))
    vp = victoria.load(t_max=T_MAX)
    player = ros.add(PlayerNode(context=ros.context, parameter_overrides=[
        Parameter('bag', value=str(bag)), Parameter('rate', value=20.0)]))
    n = len(vp.scans)
    assert ros.spin_until(lambda: player.done.is_set() and slam.n_scans == n and not len(slam.merger)
                          and len(poses) == n, timeout=90), f'{slam.n_scans}/{n} scans, {len(poses)} poses'
    assert slam.n_refused == 0 and slam.n_bad_inputs == 0 and slam.n_bad_scans == 0 and slam.n_dropped_obs == 0
    got = np.array([odometry_to_pose(m)[1] for m in poses])
    acfr = run_victoria(vp, np.random.default_rng(0))
    std = run_victoria_standard(vp, np.random.default_rng(0))
    np.testing.assert_allclose(std['pose'][:, :2], acfr['xy'], atol=1e-6)    # standard inputs = ACFR inputs
    np.testing.assert_allclose(got[:, :2], std['pose'][:, :2], atol=1e-6)     # the node adds no maths
    rmse, _, _ = victoria.gps_rmse(std['t'], got[:, :2], vp.gps)
    print(f'GPS RMSE: ACFR inputs {acfr["rmse"]:.4f} m, odometry + detections through the node {rmse:.4f} m')
    assert abs(rmse - acfr['rmse']) < 1e-4
