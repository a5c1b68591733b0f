"""``vehicle_sim``: the §5.1 vehicle and sensor field of the IDSQ paper, as topics.

- At start it draws the sensor layout with the core's seeded §5.1 generator
  (``track_core.idsq.simulation.draw_run(Scenario(...), SeedSequence(seed)).layout``: K/4 rows ×
  4 columns over the field, jittered by N(0, ``jitter_var``), round(``doa_fraction``·K) DOA
  sensors) and publishes it once on ``/idsq/layout`` (transient-local, so sensors started later
  still get it): ``sensor_msgs/PointCloud2``, one point per sensor, float32 ``x``, ``y``, ``z`` for
  the viewers, then FLOAT64 ``id``, ``x_f64``, ``y_f64``, ``type`` (0 acoustic, 1 DOA;
  ``track_msgs_py.records.idsq.layout_to_pointcloud2``). The same
  seed gives the layout of the core experiments' run with that seed.
- Every Δt of node time (``FixedRateSteps``) it publishes the vehicle truth of tracker step s on
  ``/idsq/vehicle/truth`` (``nav_msgs/Odometry``, zero covariance, velocity (0, speed),
  ``child_frame_id`` = ``vehicle_id``), stamped origin + (s + 1)·Δt: the first tick comes one period
  after the clock origin, and the vehicle enters the field (x = W/2, y = 0) then. The origin is the
  whole second of node time at start (at the first /clock if /clock has not started: the layout
  is then published first stamped 0, "origin pending", and again stamped); the layout carries it as its
  stamp, and the sensors count steps from it (``ledger.step_of_stamp``), so the field also runs on
  wall time, started by hand in any order. It stops when the
  vehicle leaves the field (``Scenario.n_steps``, 72 for §5.1) or after ``max_steps``.

With ``publish_truth:=false`` it publishes only the layout: the maritime scenario's sensors hear
other sources (the ``truth_topics`` of ``acoustic_sensor`` / ``doa_sensor``).

The sensors are separate nodes whose ``id``/``position``/``type`` parameters must match this
layout: ``track_nodes.launch.generate.idsq_yaml`` writes a launcher scenario with all of them from the same generator
(``config/idsq.yaml`` was written by it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from nav_msgs.msg import Odometry
from sensor_msgs.msg import PointCloud2

from track_core.idsq.simulation import Scenario, scenario_of
from track_msgs_py.odometry import cv_state_to_odometry
from track_msgs_py.qos import STATIC_QOS, TRUTH_QOS
from track_msgs_py.records.idsq import layout_to_pointcloud2
from track_msgs_py.topics import FRAME_MAP, IDSQ_LAYOUT, IDSQ_TRUTH
from track_nodes.base import FixedRateSteps, TrackNode, param

_SC = Scenario()

@dataclass
class VehicleSimParams:
    """Parameters of ``vehicle_sim``."""

    seed: int = param(0, 'layout seed: draw_run(Scenario, SeedSequence(seed)).layout', 0, 2**31 - 1)
    n_sensors: int = param(24, 'K sensors on a K/4 × 4 grid (a multiple of 4, §5.1)', 8, 4096)
    doa_fraction: float = param(0.3, 'fraction of DOA sensors (Table 4: 30 %)', 0.0, 1.0)
    width: float = param(_SC.width, 'field width, x (§5.1: 150 m) [m]', 1.0, 1e5)
    height: float = param(_SC.height, 'field height, y; the vehicle drives south to north (§5.1: 250 m) [m]', 1.0, 1e5)
    jitter_var: float = param(_SC.jitter_var, 'variance of the N(0, σ²) jitter of each sensor coordinate (§5.1: 25) '
                              '[m²]', 0.0, 1e6)
    speed: float = param(_SC.speed, 'vehicle speed (§5.1: 7 m/s) [m/s]', 1e-3, 1e3)
    dt: float = param(_SC.tracker.dt, 'tracker step Δt = truth period (§5.1: 0.5 s) [s]', 1e-3, 60.0)
    max_steps: int = param(0, 'stop after this many steps; 0 = when the vehicle leaves the field', 0, 10**7)
    vehicle_id: str = param('vehicle', 'child_frame_id of the truth')
    publish_truth: bool = param(True, 'publish the §5.1 vehicle; false: only the layout (the sensors then sense '
        'other sources, see the truth_topics of the sensors)')


class VehicleSimNode(TrackNode):
    DEFAULT_NAME = 'vehicle_sim'
    Params = VehicleSimParams
    p: VehicleSimParams  # the declared parameters (base/params.py)

    def setup(self) -> None:
        p = self.p
        self.scenario, self.layout, self.truth = scenario_of(p.seed, p.n_sensors, p.doa_fraction, p.width, p.height,
                                                             p.jitter_var, p.speed, p.dt)
        n = self.truth.shape[0] if p.max_steps == 0 else min(p.max_steps, self.truth.shape[0])
        self.n_steps = n
        self.published = 0
        self.pub_layout = self.create_publisher(PointCloud2, IDSQ_LAYOUT, STATIC_QOS)
        self.pub_truth = self.create_publisher(Odometry, IDSQ_TRUTH, TRUTH_QOS)
        # The layout's stamp is the step origin the sensors count from (ledger.stamp_of_step): the
        # current whole second of node time. On a /clock that has not started yet it is 0, "origin
        # pending" (ROS time 0 is unset): the sensors set up their topics at once, so nothing is
        # lost to discovery, and the layout is published again, stamped, at the first /clock.
        now_ns = self.get_clock().now().nanoseconds
        origin = None if now_ns == 0 else float(now_ns // 1_000_000_000)
        self.steps = FixedRateSteps(self, p.dt, self._step, n * p.dt, origin=origin, on_origin=self._publish_layout)
        self._publish_layout(origin or 0.0)
        self.get_logger().info(f'{self.layout.n} sensors ({int(self.layout.is_doa.sum())} DOA), '
                               f'{n} truth steps of {p.dt:g} s')

    def _publish_layout(self, origin: float) -> None:
        self.pub_layout.publish(layout_to_pointcloud2(origin, self.layout))

    def _step(self, t: float) -> None:
        s = self.steps.k - 1
        if s >= self.n_steps or not self.p.publish_truth:
            return
        x, y = self.truth[s]
        state = np.array([x, 0.0, y, self.p.speed])
        self.pub_truth.publish(cv_state_to_odometry(t, state, np.zeros((4, 4)), FRAME_MAP, self.p.vehicle_id))
        self.published += 1
