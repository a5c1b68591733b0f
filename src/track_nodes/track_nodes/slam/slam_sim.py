"""``slam_sim``: the loop-closure world of Fig. 1 (``track_core.slam.sim``), live, for the ``slam`` node.

At start the node draws one run of ``sim.simulate(LoopWorld(...), default_rng(seed))``: the true
path, the noisy vehicle inputs and the laser scans (the same generator as the ``slam-loop``
experiment). It then plays that run against node time: every ``world.dt`` (``FixedRateSteps``,
so under ``/clock`` the stamps are exact and a seed reproduces every payload) it publishes every
item whose data time has come, stamped ``origin + data time`` (origin: the whole second of node time at the first tick):

- ``/slam/scan`` (sensor_msgs/PointCloud2, ``records.slam.SlamScan``): fields ``x``, ``y``, ``z`` (the
  detection in the laser frame), ``range``, ``bearing`` (eq. 5), ``diameter`` (0: point landmarks)
  and ``landmark`` (the true landmark index, for evaluation); one every ``world.scan_every`` steps,
  also when empty;
- ``/slam/inputs`` (geometry_msgs/TwistStamped): the noisy inputs (speed, steering angle in
  ``angular.z``) applied from their stamp on;
- ``/slam/truth`` (nav_msgs/Odometry): the true laser pose (x, y, yaw), zero covariance, child frame
  ``laser_truth``, and the same pose on ``/tf`` as map → laser_truth at the truth stamps.

Frames: the scans are in ``laser`` and the inputs in ``base_link``, the frames of the vehicle as the
``slam`` node places them (map → laser → base_link, see its docstring), as on a real robot whose
localiser places its sensor frames. The simulator does not broadcast ``laser`` itself: a second
map → laser (the truth) would give the frame two parents. Its truth is a frame of its own.

At equal stamps the order is scan, input, truth. When the run is over (the vehicle has closed the
loop and driven ``world.run_on`` metres on) the node logs it once and publishes nothing more.
Parameters: ``seed``, ``max_time`` and every number field of ``LoopWorld`` as ``world.<field>``
(the vehicle geometry stays the ACFR default). The ``slam`` node's ``loop_sim`` profile matches the
default world's noise levels.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from geometry_msgs.msg import TwistStamped
from nav_msgs.msg import Odometry
from sensor_msgs.msg import PointCloud2

from track_core.slam.sim import LoopWorld, simulate
from track_msgs_py.odometry import inputs_to_twist, pose_to_odometry
from track_msgs_py.qos import qos_for_topic
from track_msgs_py.records.slam import SlamScan
from track_msgs_py.tf import odometry_transform
from track_msgs_py.topics import FRAME_LASER_TRUTH, FRAME_MAP, SLAM_INPUTS, SLAM_SCAN, SLAM_TRUTH
from track_nodes.base import FixedRateSteps, ParameterError, TrackNode, group, param


@dataclass
class SlamSimParams:
    """Parameters of ``slam_sim``."""

    seed: int = param(0, 'seed of the simulated run (truth, input and sensor noise)', 0, 2**31 - 1)
    max_time: float = param(0.0, 'stop publishing after this node time since origin [s]; 0 = never', 0.0, 1e9)
    world: LoopWorld = group(LoopWorld)


_SCAN, _INPUT, _TRUTH = 0, 1, 2
# LoopWorld does not check itself: allowed ranges of its fields (inclusive)
_WORLD_RANGES = {'width': (1.0, 1e5), 'height': (1.0, 1e5), 'speed': (0.1, 50.0), 'dt': (1e-3, 10.0),
                 'scan_every': (1, 1000), 'spacing': (0.5, 1e4), 'sparse_every': (1.0, 1e5), 'sigma_v': (0.0, 10.0),
                 'sigma_steer': (0.0, 1.0), 'sigma_r': (0.0, 100.0), 'sigma_b': (0.0, 1.0), 'max_range': (0.1, 1e4),
                 'jitter': (0.0, 1e3), 'layout_seed': (0, 2**31 - 1), 'run_on': (0.0, 1e5)}


def _check_world(w: LoopWorld) -> None:
    for name, (lo, hi) in _WORLD_RANGES.items():
        v = getattr(w, name, None)
        if v is not None and not lo <= v <= hi:
            raise ParameterError(f'parameter world.{name}={v!r} is out of range: allowed [{lo:g}, {hi:g}]')


class SlamSimNode(TrackNode):
    DEFAULT_NAME = 'slam_sim'
    Params = SlamSimParams
    p: SlamSimParams  # the declared parameters (base/params.py)

    def setup(self) -> None:
        p = self.p
        self.world = w = p.world
        _check_world(w)
        run = simulate(w, np.random.default_rng(p.seed))
        self.run = run
        items = [(float(t), _SCAN, (z, ids)) for t, z, ids in run.scans]
        items += [(float(t), _INPUT, tuple(u)) for t, u in zip(run.t, run.u_meas, strict=True)]
        items += [(k * w.dt, _TRUTH, pose) for k, pose in enumerate(run.truth)]
        items.sort(key=lambda it: (it[0], it[1]))
        self.items = items
        self.next = 0
        self._done_logged = False
        self.pub_scan = self.create_publisher(PointCloud2, SLAM_SCAN, qos_for_topic(SLAM_SCAN))
        self.pub_inputs = self.create_publisher(TwistStamped, SLAM_INPUTS, qos_for_topic(SLAM_INPUTS))
        self.pub_truth = self.create_publisher(Odometry, SLAM_TRUTH, qos_for_topic(SLAM_TRUTH))
        self.advertise_transforms()
        self.get_logger().info(f'loop world {w.width:g} x {w.height:g} m, {len(run.landmarks)} landmarks, '
                               f'{len(run.scans)} scans over {run.t[-1] + w.dt:.1f} s (seed {p.seed})')
        self.steps = FixedRateSteps(self, w.dt, self._step, p.max_time)

    @property
    def duration(self) -> float:
        """Data time of the last item [s]."""
        return self.items[-1][0]

    def _step(self, t_node: float) -> None:
        origin = self.steps.origin
        items = self.items
        while self.next < len(items) and origin + items[self.next][0] <= t_node + 1e-9:
            t_data, kind, data = items[self.next]
            self.next += 1
            t = origin + t_data
            if kind == _SCAN:
                z = np.asarray(data[0], dtype=float).reshape(-1, 2)
                extra = {'landmark': np.asarray(data[1], dtype=float)}  # the true landmark index (evaluation)
                self.pub_scan.publish(SlamScan(t, z[:, 0], z[:, 1], np.zeros(len(z)), extra).to_msg())
            elif kind == _INPUT:
                self.pub_inputs.publish(inputs_to_twist(t, *data))
            else:
                truth = pose_to_odometry(t, data, np.zeros((3, 3)), FRAME_MAP, FRAME_LASER_TRUTH)
                self.send_transforms(odometry_transform(truth))
                self.pub_truth.publish(truth)
        if self.next >= len(items) and not self._done_logged:
            self._done_logged = True
            self.get_logger().info(f'simulated run complete at t = {self.duration:.1f} s')
