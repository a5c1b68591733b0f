"""``slam``: hybrid CEKF ⇄ particle-filter SLAM (track_core.slam.HybridSlam) on motion inputs and landmark observations.

Inputs (reliable, deep queues ``queue_depth``), by ``input_model``: ``odometry``: ``/odom``
(nav_msgs/Odometry, REP-105; ``odometry_motion`` 'increments' or 'twist'; the twist covariance as
input noise with ``odometry_noise``) or ``acfr``: ``/slam/inputs`` (geometry_msgs/TwistStamped:
``linear.x`` encoder speed [m/s], ``angular.z`` steering ANGLE [rad], geometry ``acfr.L/H/a/b``).
Observations, by ``observations``: ``detections``: ``/slam/landmarks`` (LandmarkDetectionArray in
the laser frame, REP-103 bearing, at most ``max_detections``) or ``scan_cloud``: ``/slam/scan``
(PointCloud2 ``range``, ``bearing`` (eq. 5: 0 = right), ``diameter``; ``add_radius``: range +
diameter/2).

The state is the laser's position with the robot's heading (``models``). Outputs: ``/slam/pose``
(Odometry of ``base_frame`` or the laser, ``pose_of``) and its twin ``/slam/pose/pose``;
``/slam/mode`` (SlamStatus) and ``/slam/events`` (SlamEvent, one a mode switch); ``/slam/particles``
(PoseArray, after each PF scan); ``/tf`` map → odom (``odometry.map_to_odom``; with ``acfr`` and
``publish_odom_tf`` also odom → base_link), ``/tf_static`` base_link → laser (``laser_pose``);
``/slam/landmark_map`` and ``/slam/map`` (transient-local, every ``map_period`` s of data time).

Inputs and scans reach the filter in stamp order through ``streams.StreamMerger``, so the result is
the offline ``experiments.run_victoria``'s; each callback first takes what waits in both
subscriptions. Bad input is refused (``refuse``: counted per reason, throttled, on /diagnostics): an
unusable observation is dropped, a scan with none usable, a bad input, Odometry or detection array,
a stamp ahead of the clock, backwards or behind the buffer is refused before the filter. A clock
jump restarts the run at ``pose0`` (``reset_time_state``). Parameters (``slam/params.py``): the
node's, then ``cekf.*``, ``pf.*``, ``hybrid.*`` with the defaults of ``profile`` (``victoria_park``,
``loop_sim``, ``generic``). In full: docs/MODULES.md, "The slam node in full".
"""

from __future__ import annotations

import math
import time

import numpy as np
from geometry_msgs.msg import PoseArray, TwistStamped
from nav_msgs.msg import Odometry
from rclpy.clock import Clock, ClockType
from rclpy.exceptions import InvalidHandle
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import PointCloud2
from visualization_msgs.msg import MarkerArray

from track_core.filters import symmetrize
from track_core.filters.poses import OdomTrack
from track_core.slam import HybridSlam
from track_core.slam.blas import single_threaded_blas
from track_core.slam.landmarks import to_eq5_bearing
from track_core.slam.models import UnicycleParams, acfr_to_unicycle
from track_core.slam.odometry import OdometryInputs, base_to_sensor, map_to_odom, sensor_to_base
from track_core.slam.streams import INPUT, SCAN, StreamMerger, scan_observations
from track_msgs import msg as tm
from track_msgs_py.markers.slam import map_markers
from track_msgs_py.odometry import pose_to_odometry, positions_to_pose_array, twist_to_inputs
from track_msgs_py.qos import ESTIMATE_QOS, SENSOR_QOS, STATIC_QOS
from track_msgs_py.records import RecordError
from track_msgs_py.records.landmarks import LandmarkDetections, LandmarkMap, PlanarOdometry
from track_msgs_py.records.slam import SlamEvent, SlamMode, SlamScan
from track_msgs_py.stamps import stamp_to_ns
from track_msgs_py.tf import frame_pair_problem, planar_transform
from track_msgs_py.topics import (
    SLAM_EVENTS,
    SLAM_INPUTS,
    SLAM_LANDMARK_MAP,
    SLAM_LANDMARKS,
    SLAM_MAP,
    SLAM_MODE,
    SLAM_ODOM,
    SLAM_PARTICLES,
    SLAM_POSE,
    SLAM_SCAN,
)
from track_msgs_py.validate import (
    InputPolicy,
    clock_now,
    odometry_bounds_problem,
    odometry_problem,
    speed_steer_problem,
    stamp_problem,
)
from track_nodes.base import ParameterError, TrackNode, run_node, vector
from track_nodes.slam.params import SlamNodeParams


class SlamNode(TrackNode):
    DEFAULT_NAME = 'slam'
    Params = SlamNodeParams
    p: SlamNodeParams  # the declared parameters (base/params.py)

    @classmethod
    def main(cls, argv=None, **kwargs) -> int:
        # One BLAS thread for the whole process: the CEKF's small products otherwise spin OpenBLAS
        # workers on a busy machine (track_core/slam/blas.py measures 10x and more).
        with single_threaded_blas():
            return run_node(cls, argv, **kwargs)

    def setup(self) -> None:
        p = self.p
        self._new_slam = self._filter_factory()
        self.slam = self._new_slam()
        self.odom_inputs = OdometryInputs(p.odometry_motion)
        self.odom = OdomTrack()   # odom -> base_link over time: the driver's odometry, or dead-reckoned acfr inputs
        self._odom_last_ns: int | None = None
        self.policy = InputPolicy(horizon=p.stamp_horizon, lead=p.stamp_lead)
        self.refusals.throttle = p.warn_throttle
        self.merger = StreamMerger(p.pause_wall, p.flush_idle, p.drain_budget, time.monotonic())
        self._heard: dict[str, float | None] = {INPUT: None, SCAN: None}  # last message per stream, even refused
        self._map_ns: int | None = None  # stamp of the last map published
        self._map_dirty = self._pf_published = False  # a scan since that map; the last cloud was not empty
        self._n_events = 0
        self.n_inputs = self.n_scans = 0
        self.n_dropped_obs = self.n_bad_inputs = self.n_bad_scans = self.n_refused = 0
        self.pub_pose = self.create_publisher(Odometry, SLAM_POSE, ESTIMATE_QOS)
        self.pub_mode = self.create_publisher(tm.SlamStatus, SLAM_MODE, ESTIMATE_QOS)
        self.pub_events = self.create_publisher(tm.SlamEvent, SLAM_EVENTS, ESTIMATE_QOS)
        self.pub_particles = self.create_publisher(PoseArray, SLAM_PARTICLES, SENSOR_QOS)
        self.pub_map = self.create_publisher(MarkerArray, SLAM_MAP, STATIC_QOS)
        self.pub_landmark_map = self.create_publisher(LandmarkMap.msg_type(), SLAM_LANDMARK_MAP, STATIC_QOS)
        qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=p.queue_depth,
                         reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
        if p.input_model == 'acfr':
            self._input_topic = SLAM_INPUTS
            self.sub_inputs = self.create_subscription(TwistStamped, SLAM_INPUTS, self._on_input, qos)
        else:
            self._input_topic = SLAM_ODOM
            self.sub_inputs = self.create_subscription(Odometry, SLAM_ODOM, self._on_input, qos)
        if p.observations == 'scan_cloud':
            self._scan_topic = SLAM_SCAN
            self.sub_scan = self.create_subscription(PointCloud2, SLAM_SCAN, self._on_scan, qos)
        else:
            self._scan_topic = SLAM_LANDMARKS
            self.sub_scan = self.create_subscription(LandmarkDetections.msg_type(), SLAM_LANDMARKS, self._on_scan, qos)
        # base_link -> laser: the laser's mounting (acfr: a ahead, b left of the rear-axle centre)
        self.add_static_transforms(planar_transform(0.0, p.base_frame, p.child_frame_id, *self.laser))
        self.advertise_transforms()
        self.create_timer(min(0.1, p.flush_idle / 2), self._on_idle, clock=Clock(clock_type=ClockType.STEADY_TIME))

    def _filter_factory(self):
        """The input model, the laser's place and the frames from the parameters (checked); → a maker of the filter."""
        p = self.p
        pose0, var0 = vector('pose0', p.pose0, 3), vector('pose0_var', p.pose0_var, 3, positive=True)
        if p.input_model == 'acfr':
            vehicle = p.acfr
            self.laser = (vehicle.a, vehicle.b, 0.0)
        else:
            self.laser = tuple(float(v) for v in vector('laser_pose', p.laser_pose, 3))
            vehicle = UnicycleParams(a=self.laser[0], b=self.laser[1])
            pose0 = base_to_sensor(pose0, self.laser[0], self.laser[1])  # pose0 is base_frame's: start the laser
            if p.publish_odom_tf:
                raise ParameterError('parameter publish_odom_tf=True with input_model=odometry: the driver that '
                                     'publishes the odometry owns odom -> base_link')
        chain = (p.frame_id, p.odom_frame, p.base_frame, p.child_frame_id)
        problem = (frame_pair_problem(p.frame_id, p.odom_frame) or frame_pair_problem(p.odom_frame, p.base_frame)
                   or frame_pair_problem(p.base_frame, p.child_frame_id)
                   or (None if len(set(chain)) == 4 else 'the four frames must differ'))
        if problem:
            raise ParameterError(f'parameters frame_id={p.frame_id!r}, odom_frame={p.odom_frame!r}, base_frame='
                                 f'{p.base_frame!r}, child_frame_id={p.child_frame_id!r}: {problem}')
        return lambda: HybridSlam(pose0, np.diag(var0), np.random.default_rng(p.seed), p.cekf, p.pf, p.hybrid,
                                  compressed=p.compressed, vehicle=vehicle)

    def reset_time_state(self) -> tuple[str, ...]:
        """A new run (a clock jump): the filter at pose0 (seeded again), the stream merger, the map clock."""
        self.slam = self._new_slam()
        self.merger.reset(time.monotonic())
        self._map_ns, self._map_dirty, self._pf_published, self._n_events = None, False, False, 0
        self.odom_inputs.reset()
        self.odom.reset()
        self._odom_last_ns = None
        return ('filter (at pose0, seeded again)', 'stream merger', 'map schedule', 'odometry')

    @property
    def processed_ns(self) -> int | None:  # stamp of the last event the filter took
        return self.merger.processed_ns

    def _on_input(self, msg: TwistStamped | Odometry) -> None:
        self._add_input(msg)
        self._after_message()

    def _on_scan(self, msg) -> None:
        self._add_scan(msg)
        self._after_message()

    def _after_message(self) -> None:
        self._take_pending()
        self.merger.end_callback(self._step, time.monotonic, self._heard)

    def _on_idle(self) -> None:
        now = time.monotonic()
        took = self._take_pending() > 0
        if self.merger.on_idle(now, took, self._step, time.monotonic, self._heard) and self._map_dirty:
            self._publish_map(self.processed_ns / 1_000_000_000)  # int / int: the float nearest to the stamp

    def _take_pending(self) -> int:
        """Take every message already waiting in both subscriptions into the merger (the executor's
        order is not fair under a backlog), with the executor's own ``take_message``; without it the
        node falls back to the executor's order. → the number of messages taken."""
        taken = 0
        for sub, add in ((self.sub_inputs, self._add_input), (self.sub_scan, self._add_scan)):
            for _ in range(self.p.queue_depth):
                try:
                    with sub.handle:
                        info = sub.handle.take_message(sub.msg_type, sub.raw)
                except (AttributeError, TypeError, RuntimeError, InvalidHandle):
                    return taken
                if info is None:
                    break
                add(info[0])
                taken += 1
        return taken

    def _add_input(self, msg: TwistStamped | Odometry) -> None:
        self._heard[INPUT] = time.monotonic()  # refused or not, the stream is not silent (streams: pause rule)
        if self.p.input_model == 'odometry':
            self._add_odometry(msg)
            return
        _, speed, steer = twist_to_inputs(msg)
        reason = speed_steer_problem(speed, steer, self.policy)
        if reason:
            self.n_bad_inputs += 1
            self.refuse(SLAM_INPUTS, reason)
            return
        self._offer(INPUT, msg.header.stamp, (speed, steer))

    def _add_odometry(self, msg: Odometry) -> None:
        """The robot's odometry (REP-105): frames, numbers and stamp checked, then its input(s) into the merger
        (``odometry.OdometryInputs``) and its pose into the odom track; nothing changes when refused."""
        p = self.p
        reason = (odometry_problem(msg, {p.odom_frame})
                  or (None if msg.child_frame_id == p.base_frame else
                      f'child_frame_id: {msg.child_frame_id!r}, expected base_frame {p.base_frame!r}')
                  or odometry_bounds_problem(msg, self.policy, pose_covariance=False))
        if reason is None:
            try:
                odo = PlanarOdometry.from_msg(msg)
            except RecordError as exc:
                reason = str(exc)
        if reason is None:
            t_ns = stamp_to_ns(msg.header.stamp)
            reason = stamp_problem(t_ns / 1e9, clock_now(self.get_clock().now().nanoseconds), self.policy,
                                   required=False)
            if reason is None and self._odom_last_ns is not None and t_ns < self._odom_last_ns:
                reason = (f'header.stamp: {t_ns * 1e-9:.9f} s is before the previous one '
                          f'{self._odom_last_ns * 1e-9:.9f} s (time went backwards)')
            if reason is None and self.merger.processed_ns is not None and t_ns < self.merger.processed_ns:
                reason = f'header.stamp: {t_ns * 1e-9:.9f} s arrived after data up to it was processed'
        if reason is not None:
            self.n_bad_inputs += 1
            self.refuse(SLAM_ODOM, reason)
            return
        self._odom_last_ns = t_ns
        cov = odo.cov if p.odometry_noise == 'covariance' else None
        self.odom.add(t_ns / 1_000_000_000, odo.pose, odo.v, odo.w)
        for _, v, w, c, stamp in self.odom_inputs.offer(t_ns / 1_000_000_000, odo.pose, odo.v, odo.w, cov,
                                                       msg.header.stamp):
            self._offer(INPUT, stamp, (v, w, c))

    def _add_scan(self, msg) -> None:
        self._heard[SCAN] = time.monotonic()
        p = self.p
        try:
            if p.observations == 'scan_cloud':
                scan = SlamScan.from_msg(msg)
                bearing, add_radius = scan.bearing, p.add_radius
            else:
                scan = LandmarkDetections.from_msg(msg, p.max_detections)
                if scan.frame_id != p.child_frame_id:
                    raise RecordError(f'header.frame_id: {scan.frame_id!r}, detections must be in the laser frame '
                                      f'{p.child_frame_id!r}')
                # REP-103 in the laser frame -> eq. 5 (0 = right) about the robot heading
                bearing, add_radius = to_eq5_bearing(scan.bearing + self.laser[2]), False
            if scan.range.size > p.max_detections:
                raise RecordError(f'{scan.range.size} observations, more than max_detections {p.max_detections}')
        except RecordError as exc:
            self.n_bad_scans += 1
            self.refuse(self._scan_topic, f'scan: {exc}')
            return
        limits = self.slam.params.bearing_limits
        z, ok = scan_observations(scan.range, bearing, scan.diameter, limits, self.p.bearing_tolerance,
                                  add_radius, self.policy.world_bound)
        example = f'e.g. range {scan.range[~ok][0]:.4g}, bearing {scan.bearing[~ok][0]:.4g}' if not ok.all() else ''
        if ok.size and not ok.any():  # garbage, not an empty scan: refused before its stamp reaches the merger
            self.n_bad_scans += 1
            self.refuse(self._scan_topic, f'scan: no usable observation of {ok.size} (streams.scan_observations), '
                        f'{example}')
            return
        if self._offer(SCAN, msg.header.stamp, z) and not np.all(ok):
            bad = int(np.sum(~ok))
            self.n_dropped_obs += bad
            self.refuse(self._scan_topic, f'observations dropped: {bad} of {ok.size} at t = {scan.t:.3f} s (streams.'
                        f'scan_observations), {example}')

    def _offer(self, stream: str, stamp, payload) -> bool:
        """Into the merger; False (refused, warned) when the stamp is malformed, backwards or too late."""
        if not 0 <= stamp.nanosec < 1_000_000_000:
            reason = f'header.stamp: malformed stamp (nanosec {stamp.nanosec})'
        else:
            reason = (stamp_problem(stamp_to_ns(stamp) / 1e9, clock_now(self.get_clock().now().nanoseconds),
                                    self.policy, required=False)
                      or self.merger.offer(stream, stamp_to_ns(stamp), payload, time.monotonic()))
        if reason is None:
            return True
        self.n_refused += 1
        topic = self._input_topic if stream == INPUT else self._scan_topic
        self.refuse(topic, reason if reason.startswith('header.') else f'header.stamp: {reason}')
        return False

    # -- core step and outputs ------------------------------------------------------------------
    def _step(self, stream: str, t_ns: int, payload) -> bool:
        """One released event into the filter; False when the core refused it (state unchanged)."""
        t = t_ns / 1_000_000_000  # == stamp_to_sec: int / int is the nearest float (t_ns / 1e9 is not)
        if stream == INPUT:
            ok = self.slam.process_input(t, *payload)
            self.n_inputs += ok
            if ok and self.p.input_model == 'acfr':  # dead reckoning: the odometry a driver of the car would give
                v, w, _ = acfr_to_unicycle(payload[0], payload[1], self.p.acfr)
                self.odom.integrate(t, float(v), float(w))
            if ok and self.n_inputs == 1 and not self.n_scans:  # the tree from the data's start on
                self._send_tf(t)
        else:
            ok = self.slam.process_scan(t, payload)
            self.n_scans += ok
        if not ok:  # the node's own checks should make this unreachable
            self.n_refused += 1
        elif stream == SCAN:
            self._after_scan(t, t_ns)
        return ok

    def _after_scan(self, t: float, t_ns: int) -> None:
        s, p = self.slam, self.p
        self._map_dirty = True
        if refused := s.cekf.take_refused_landmarks():  # the map-size cap: counted, one throttled line
            self.refuse(self._scan_topic, f'cekf.max_landmarks: the map holds {p.cekf.max_landmarks}; {refused} new '
                                          'landmark(s) of this scan refused')
        for ev in s.events[self._n_events:]:
            self._publish_event(ev)
        self._n_events = len(s.events)
        pose = self._pose_msg(t)
        self._send_tf(t)
        self.pub_pose.publish(pose)
        pf_step = s.last_particles
        if pf_step is not None and pf_step.scan == s.n_scans:  # the PF ran on this scan (maybe its last)
            parts = pf_step.particles[::max(1, math.ceil(len(pf_step.particles) / p.max_particles_published))]
            self.pub_particles.publish(positions_to_pose_array(t, parts[:, :2], p.frame_id, headings=parts[:, 2]))
            self._pf_published = True
        elif self._pf_published:
            self.pub_particles.publish(positions_to_pose_array(t, np.zeros((0, 2)), p.frame_id))
            self._pf_published = False
        mode = SlamMode(s.mode, self.n_scans, self.n_inputs, len(s.landmarks()),
                        sum(e.kind == 'to_pf' for e in s.events),
                        s.ctx.pf.n_scans if s.mode == 'PF' and s.ctx is not None else 0,
                        self.n_dropped_obs, self.n_refused, self.n_bad_inputs, self.n_bad_scans)
        self.pub_mode.publish(mode.to_msg(t))
        if self._map_ns is None or t_ns - self._map_ns >= round(p.map_period * 1e9):
            self._publish_map(t)

    def _pose(self) -> tuple[np.ndarray, np.ndarray]:
        """The estimate as base_frame's pose in map (``odometry.sensor_to_base``) and its covariance."""
        s = self.slam
        return sensor_to_base(s.pose, symmetrize(s.pose_cov), self.laser[0], self.laser[1])

    def _pose_msg(self, t: float) -> Odometry:
        s, p = self.slam, self.p
        if p.pose_of == 'laser':
            return pose_to_odometry(t, s.pose, symmetrize(s.pose_cov), p.frame_id, p.child_frame_id)
        base, P = self._pose()
        return pose_to_odometry(t, base, symmetrize(P), p.frame_id, p.base_frame)

    def _send_tf(self, t: float) -> None:
        """map -> odom from the estimate and odom -> base_link at ``t`` (``odometry.map_to_odom``), as slam_toolbox
        and robot_localization do; with ``publish_odom_tf`` (acfr inputs, no driver) odom -> base_link too."""
        p = self.p
        try:
            base_odom = self.odom.pose_at(t)
        except LookupError:  # no odometry yet: nothing to place odom with
            return
        mo = map_to_odom(self._pose()[0], base_odom)
        transforms = [planar_transform(t, p.frame_id, p.odom_frame, *mo)]
        if p.publish_odom_tf:
            transforms.append(planar_transform(t, p.odom_frame, p.base_frame, *base_odom))
        self.send_transforms(*transforms)

    def _publish_event(self, ev) -> None:
        x, y, yaw = (float(v) for v in self.slam.pose)
        rec = SlamEvent(ev.kind, ev.t, ev.scans, x, y, yaw)
        self.pub_events.publish(rec.to_msg(self.p.frame_id))
        self.get_logger().info(f't = {ev.t:.3f} s: {rec.text}' + (f' after {ev.scans} PF scans' if ev.scans else ''))

    def _publish_map(self, t: float) -> None:
        self._map_ns = round(t * 1e9)
        self._map_dirty = False
        lm, covs = self.slam.map_estimate()
        self.pub_map.publish(map_markers(t, lm, covs, self.p.frame_id, self.p.ellipse_points))
        self.pub_landmark_map.publish(LandmarkMap(t, self.p.frame_id, np.arange(len(lm)), lm, covs).to_msg())
