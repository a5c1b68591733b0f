"""``vehicle_sim``: the §5.1 vehicle and sensor field of the IDSQ paper, as topics, and the
simulator that stands in for every sensor's front end.

- Layout: drawn at start by the core's seeded §5.1 generator (``track_core.idsq.simulation.
  draw_run(Scenario(...), SeedSequence(seed)).layout``: K/4 rows × 4 columns, jitter N(0,
  ``jitter_var``), round(``doa_fraction``·K) DOA sensors), published once on the transient-local
  ``/idsq/layout`` (``records.idsq.layout_to_pointcloud2``); the same seed gives the core
  experiments' layout.
- Truth: every Δt of node time (``FixedRateSteps``) the vehicle of step s on ``/idsq/vehicle/truth``
  (Odometry, zero covariance, velocity (0, speed), ``child_frame_id`` = ``vehicle_id``), stamped
  origin + (s + 1)·Δt; the origin is the whole second of node time at start (the layout's stamp; 0 =
  "origin pending" before /clock); it stops when the vehicle leaves the field (``Scenario.n_steps``,
  72 for §5.1) or after ``max_steps``.
- Readings: every sensor's on ``/idsq/sensor_<id>/reading`` (reliable, transient-local, depth 256),
  stamped like the step's truth, drawn by ``track_core.idsq.readings`` with §5.1's noise (A/r + N(0,
  0.05²); θ + N(0, (3°)²), sent as a REP-103 direction) and the keys ``measurement_normal(seed,
  sensor, step)``. Sources: this node's vehicle, or the Odometry topics in ``truth_topics`` (each
  sensor hears its nearest source, ``FieldSimulator``); a truth off the step grid or unreadable is
  refused. ``publish_truth:=false``: no vehicle (the maritime scenario). The sensor nodes'
  ``id``/``position``/``type`` must match the layout (``track_nodes.idsq.scenario_files.idsq_yaml``
  writes them; ``config/idsq.yaml``). In full: docs/MODULES.md, "The vehicle_sim node in full".
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np
from nav_msgs.msg import Odometry
from rclpy.event_handler import PublisherEventCallbacks
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import PointCloud2

from track_core.idsq.leader_protocol import stamp_of_step, step_of_stamp
from track_core.idsq.models import DEG, SimNoise
from track_core.idsq.readings import MAX_PENDING, FieldSimulator, Reading, field_readings
from track_core.idsq.simulation import Scenario, scenario_of
from track_msgs import msg as tm
from track_msgs_py.odometry import cv_state_to_odometry, odometry_to_cv_state
from track_msgs_py.qos import READING_LATCHED_QOS, STATIC_QOS, TRUTH_QOS
from track_msgs_py.records.idsq import IdsqReading, layout_to_pointcloud2
from track_msgs_py.stamps import stamp_to_sec
from track_msgs_py.topics import FRAME_MAP, IDSQ_LAYOUT, IDSQ_TRUTH, KNOWN_FRAMES, idsq_reading_topic
from track_msgs_py.validate import odometry_problem
from track_nodes.base import FixedRateSteps, TrackNode, param

_SC = Scenario()
_NOISE = SimNoise()
SOURCE_TRUTH_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=256, reliability=ReliabilityPolicy.RELIABLE)

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
    publish_truth: bool = param(True, 'publish the §5.1 vehicle; false: no vehicle (the sensors then hear the '
        'sources of truth_topics)')
    truth_topics: list[str] = param([''], 'Odometry truth topics of the sources the sensors hear (each its nearest); '
                                    'empty: the §5.1 vehicle of this node')
    publish_readings: bool = param(True, "publish every sensor's simulated reading per step (false: real front ends "
                                   'publish them)')
    amplitude: float = param(_NOISE.amplitude, 'simulated source amplitude A (§5.1: 40)', 1e-6, 1e6)
    noise_sigma_a: float = param(_NOISE.sigma_a, 'simulated amplitude noise std (§5.1: 0.05)', 0.0, 1e3)
    noise_sigma_doa_deg: float = param(_NOISE.sigma_doa / DEG, 'simulated DOA noise std (§5.1: 3°) [deg]', 0.0, 180.0)


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
        self.readings_published = 0
        self.noise = SimNoise(amplitude=p.amplitude, sigma_a=p.noise_sigma_a, sigma_doa=p.noise_sigma_doa_deg * DEG)
        self.truth_topics = tuple(t for t in p.truth_topics if t)
        self.origin: float | None = None  # the layout's stamp (FixedRateSteps' origin), once fixed
        self.pub_layout = self.create_publisher(PointCloud2, IDSQ_LAYOUT, STATIC_QOS)
        self.pub_truth = self.create_publisher(Odometry, IDSQ_TRUTH, TRUTH_QOS)
        self.pub_readings = [self.create_publisher(tm.IdsqReading, idsq_reading_topic(k), READING_LATCHED_QOS,
                                                   event_callbacks=PublisherEventCallbacks(use_default_callbacks=False))
                             for k in range(self.layout.n)] if p.publish_readings else []
        self.field = FieldSimulator(self.layout, self.noise, p.seed, self.truth_topics) if self.truth_topics else None
        self.early: deque[tuple[Odometry, str]] = deque(maxlen=MAX_PENDING)  # truths before the origin
        for topic in self.truth_topics if p.publish_readings else ():
            self.create_subscription(Odometry, topic, lambda m, topic=topic: self._on_truth(m, topic),
                                     TRUTH_QOS if topic == IDSQ_TRUTH else SOURCE_TRUTH_QOS)
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
        if origin:
            self.origin = origin
        self.pub_layout.publish(layout_to_pointcloud2(origin, self.layout))
        while self.origin is not None and self.early:  # the truths that came first, in their order
            self._on_truth(*self.early.popleft())

    def _step(self, t: float) -> None:
        s = self.steps.k - 1
        if s >= self.n_steps or not self.p.publish_truth:
            return
        x, y = self.truth[s]
        state = np.array([x, 0.0, y, self.p.speed])
        self.pub_truth.publish(cv_state_to_odometry(t, state, np.zeros((4, 4)), FRAME_MAP, self.p.vehicle_id))
        self.published += 1
        if self.field is None:  # the sensors hear this vehicle
            self._publish_readings(t, field_readings(self.truth[s], self.layout, s, self.noise, self.p.seed))

    def _on_truth(self, msg: Odometry, topic: str) -> None:
        """A source's truth of ``topic``: once every topic has delivered its step, that step's readings."""
        if self.origin is None:  # steps count from the layout's stamp: hold the truth until it is fixed
            self.early.append((msg, topic))
            return
        t = stamp_to_sec(msg.header.stamp)
        step = step_of_stamp(t, self.p.dt, self.origin)
        reason = odometry_problem(msg, KNOWN_FRAMES)
        if reason is None and step is None:
            reason = f'header.stamp: {t - self.origin:.9f} s after the origin is not (s + 1)·dt for dt={self.p.dt} s'
        if reason is not None:
            self.refuse(topic, reason)
            return
        _, x, _ = odometry_to_cv_state(msg)
        readings = self.field.on_truth(step, topic, msg.child_frame_id, x[[0, 2]])
        if readings:
            self._publish_readings(stamp_of_step(step, self.p.dt, self.origin), readings)

    def _publish_readings(self, t: float, readings: list[Reading]) -> None:
        if not self.pub_readings:
            return
        for r in readings:
            self.pub_readings[r.sensor].publish(IdsqReading.of_reading(t, r).to_msg())
        self.readings_published += 1
