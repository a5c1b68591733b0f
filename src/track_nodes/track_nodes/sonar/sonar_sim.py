"""``sonar_sim``: the observer ship and its sonar, simulated: a sensor like any other for ``sonar_observer``.

It sails the observer's route (``ObserverTrajectory``: constant speed, straight legs and constant-rate
turns) and, for every target truth (``/sonar/target/truth``), reads the target with the sonar mode the
observer asked for (``/sonar/mode_command``, ``track_msgs/SonarModeCommand``): eq. 5 passive bearing or
eq. 6 active bearing and range, Table 1's noise (``sigma_b_deg``, ``sigma_d``), from its own seeded
Generator. Per step k (stamped exactly as the truth t_k) it publishes, in this order:

- ``/sonar/ping`` (geometry_msgs/PointStamped at the observer), only when it pinged: the sound the
  smart target may hear;
- ``/sonar/contacts`` (``track_msgs/SonarContact``): the reading, bearing REP-103 in ``contact_frame``
  (the world frame: a true bearing; or ``observer_id``, the ship's body frame: relative to its heading),
  with the noise stds;
- ``/sonar/observer/odom`` (nav_msgs/Odometry, REP-105: pose in the world frame, heading along the
  velocity, forward speed in ``child_frame_id`` = ``observer_id``) last, just after the same pose on
  ``/tf`` (world → ``observer_id``): the ship's navigation, and for the smart target "sonar step k done".

Determinism (``track_core.sonar.lockstep``): the first truth accepted is step 1 and fixes the step grid;
steps are taken in grid order (``TruthGate``), and with ``lockstep`` (default) step k waits for the
observer's request stamped t_{k-1} (the first step for any request, e.g. the observer's start request),
so the sonar pings exactly when eq. 7 asked (``CommandGate``). If no request comes within
``command_timeout`` of steady time, the step is taken with the latest request (or ``initial_mode``) and
one line says so. ``lockstep:=false`` obeys the latest request like a real sonar driver. The noise
Generator is the first of ``SeedSequence(seed).spawn(2)``: the stream the observer drew its own readings
from before the estimator and the sensor were split, so a scenario seed gives the same readings.
A jump of the clock (a bag looped, a simulator reset) starts a new run: the Generator seeded again and
the step grid forgotten.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from geometry_msgs.msg import PointStamped
from nav_msgs.msg import Odometry

from track_core.sonar import ObserverTrajectory, SensorMode, SonarParams
from track_core.sonar.contacts import simulated_contact
from track_core.sonar.lockstep import CommandGate, TruthGate
from track_core.sonar.scenario import DEFAULT_LEGS
from track_msgs import msg as tm
from track_msgs_py.odometry import odometry_to_cv_state
from track_msgs_py.qos import ESTIMATE_QOS, STATIC_QOS, TRUTH_QOS
from track_msgs_py.records import RecordError
from track_msgs_py.records.sonar import contact_to_msg, fix_to_odometry, mode_command_from_msg
from track_msgs_py.stamps import ns_to_stamp, stamp_to_ns
from track_msgs_py.tf import frame_pair_problem, odometry_transform
from track_msgs_py.topics import (
    FRAME_MAP,
    KNOWN_FRAMES,
    SONAR_CONTACTS,
    SONAR_MODE_COMMAND,
    SONAR_OBSERVER,
    SONAR_PING,
    SONAR_TRUTH,
)
from track_msgs_py.validate import InputPolicy, clock_now, odometry_bounds_problem, odometry_problem, stamp_problem
from track_nodes.base import ParameterError, TrackNode, param

MODES = tuple(m.value for m in SensorMode)


@dataclass
class SonarSimParams:
    """Parameters of ``sonar_sim``."""

    seed: int = param(0, 'seed of the reading noise (the first of two spawned streams)', 0, 2**31 - 1)
    period: float = param(1.0, 'sampling period T of the truths (Table 1: 1 s): step k is at route time k·T [s]',
                          1e-3, 60.0)
    sigma_b_deg: float = param(1.0, 'bearing noise std σ_b (Table 1: 1°) [deg]', 1e-6, 180.0)
    sigma_d: float = param(5.0, 'range noise std σ_d of the active sonar (Table 1: 5 m) [m]', 1e-6, 1e6)
    start: list[float] = param([0.0, 0.0], 'observer start position [x, y] in the world frame [m]')
    speed: float = param(10.0, 'observer speed [m/s]', 0.0, 1e3)
    heading0_deg: float = param(90.0, 'observer initial heading, clockwise from north [deg]', -360.0, 360.0)
    legs: list[float] = param([float(v) for leg in DEFAULT_LEGS for v in leg], 'observer legs, flat [duration s, turn '
                              'rate deg/s, ...]; the last leg extends past its duration')
    observer_id: str = param('sonar_observer', "the ship's body frame: child_frame_id of its navigation")
    contact_frame: str = param('world', "frame of the contacts' bearings: world (true bearings) or body "
                               "(relative to the ship's heading, in observer_id)", choices=('world', 'body'))
    lockstep: bool = param(True, "step k waits for the observer's request stamped t_{k-1} (deterministic runs)")
    initial_mode: str = param('active', 'sonar mode before any request has come (lockstep off, or a timeout)',
                              choices=MODES)
    command_timeout: float = param(10.0, "lockstep: steady seconds to wait for the observer's request before the "
                                   'step is taken with the latest one', 0.1, 1e6, live=True)
    max_time: float = param(0.0, 'stop after step k with k·T > max_time (route time) [s]; 0 = never', 0.0, 1e9)
    stamp_lead: float = param(3.0, 'refuse truths stamped more than this ahead of the node clock [s]', 1e-3, 1e9,
                              live=True)


class SonarSimNode(TrackNode):
    DEFAULT_NAME = 'sonar_sim'
    Params = SonarSimParams
    p: SonarSimParams

    def setup(self) -> None:
        p = self.p
        legs = np.asarray(p.legs, dtype=float)
        if legs.size == 0 or legs.size % 2 or not np.all(np.isfinite(legs)) or np.any(legs[::2] <= 0):
            raise ParameterError(f'parameter legs={list(p.legs)!r} is invalid: allowed pairs [duration > 0 s, '
                                 'turn rate deg/s, ...]')
        start = np.asarray(p.start, dtype=float)
        if start.shape != (2,) or not np.all(np.isfinite(start)):
            raise ParameterError(f'parameter start={list(p.start)!r} is invalid: allowed 2 finite numbers [x, y]')
        problem = frame_pair_problem(FRAME_MAP, p.observer_id)
        if problem:
            raise ParameterError(f'parameter observer_id={p.observer_id!r}: {problem}')
        self.sonar = SonarParams(T=p.period, sigma_b=math.radians(p.sigma_b_deg), sigma_d=p.sigma_d)
        self.trajectory = ObserverTrajectory(start=(float(start[0]), float(start[1])), speed=p.speed,
                                             heading0_deg=p.heading0_deg,
                                             legs=tuple((float(d), float(r)) for d, r in legs.reshape(-1, 2)))
        self.rejected = 0
        self._start_run()
        self.pub_ping = self.create_publisher(PointStamped, SONAR_PING, ESTIMATE_QOS)
        self.pub_contact = self.create_publisher(tm.SonarContact, SONAR_CONTACTS, ESTIMATE_QOS)
        self.pub_nav = self.create_publisher(Odometry, SONAR_OBSERVER, ESTIMATE_QOS)
        self.advertise_transforms()
        self.sub_command = self.create_subscription(tm.SonarModeCommand, SONAR_MODE_COMMAND, self._on_command,
                                                    STATIC_QOS)
        self.sub_truth = self.create_subscription(Odometry, SONAR_TRUTH, self._on_truth, TRUTH_QOS)
        self.wait_timer = self.create_timer(0.5, self._check_command_wait, clock=self._steady)

    def _start_run(self) -> None:
        noise_ss, _ = np.random.SeedSequence(self.p.seed).spawn(2)
        self.rng = np.random.default_rng(noise_ss)
        self.truths = TruthGate(round(self.p.period * 1e9))
        self.commands = CommandGate(self.p.lockstep, SensorMode(self.p.initial_mode))
        self._waiting_since: float | None = None
        self.k = 0
        self.pings = 0

    def reset_time_state(self) -> tuple[str, ...]:
        self._start_run()
        return ('reading noise (seeded again)', 'truth gate (step grid)', 'requests')

    # -- inputs ---------------------------------------------------------------------------
    def _on_command(self, msg: tm.SonarModeCommand) -> None:
        try:
            key, mode = mode_command_from_msg(msg)
        except RecordError as exc:
            self.rejected += 1
            self.refuse(SONAR_MODE_COMMAND, str(exc))
            return
        self._take(self.commands.add_command(key, mode))

    def _on_truth(self, msg: Odometry) -> None:
        key = stamp_to_ns(msg.header.stamp)
        reason = (odometry_problem(msg, KNOWN_FRAMES) or odometry_bounds_problem(msg, pose_covariance=False)
                  or stamp_problem(key * 1e-9, clock_now(self.get_clock().now().nanoseconds),
                                   InputPolicy(lead=self.p.stamp_lead))
                  or self.truths.problem(key))
        if reason:
            self.rejected += 1
            self.refuse(SONAR_TRUTH, reason)
            return
        _, x, _ = odometry_to_cv_state(msg)
        for k, key_k, x_k in self.truths.add_truth(key, x):
            if self.p.max_time > 0 and k * self.p.period > self.p.max_time + 1e-9:
                break
            self._take(self.commands.add_step(k, key_k, x_k))

    def _check_command_wait(self) -> None:
        waiting = self.commands.waiting()
        now = self.steady_now()
        if waiting is None:
            self._waiting_since = None
        elif self._waiting_since is None:
            self._waiting_since = now
        elif now - self._waiting_since >= self.p.command_timeout:
            self.get_logger().warning(f'no request on {self.sub_command.topic_name} stamped {max(waiting, 0)} ns for '
                                      f'{self.p.command_timeout:g} s (is sonar_observer running?): reading with the '
                                      'latest request', throttle_duration_sec=60.0)
            self._waiting_since = None
            self._take(self.commands.force())

    # -- one step -------------------------------------------------------------------------
    def _take(self, ready) -> None:
        for k, key, x_true, mode in ready:
            self._step(k, key, x_true, mode)

    def _step(self, k: int, key: int, x_true: np.ndarray, mode: SensorMode) -> None:
        self.k = k
        stamp = ns_to_stamp(key)
        obs_state = self.trajectory.state(k * self.p.period)  # route time since step 0
        obs_xy, vel = obs_state[[0, 2]], obs_state[[1, 3]]
        heading = math.atan2(vel[1], vel[0]) if self.p.contact_frame == 'body' else None
        contact = simulated_contact(self.rng, key, x_true, obs_xy, mode, self.sonar, heading)
        if mode is SensorMode.ACTIVE:
            self.pings += 1
            ping = PointStamped()
            ping.header.stamp, ping.header.frame_id = stamp, FRAME_MAP
            ping.point.x, ping.point.y = float(obs_xy[0]), float(obs_xy[1])
            self.pub_ping.publish(ping)
        frame = self.p.observer_id if self.p.contact_frame == 'body' else FRAME_MAP
        self.pub_contact.publish(contact_to_msg(contact, frame))
        nav = fix_to_odometry(key, obs_xy, vel, FRAME_MAP, self.p.observer_id)
        self.send_transforms(odometry_transform(nav))
        self.pub_nav.publish(nav)  # last: the target's step k+1 waits for it
