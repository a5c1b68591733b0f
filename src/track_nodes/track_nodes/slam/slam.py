"""``slam``: hybrid CEKF ⇄ particle-filter SLAM (track_core.slam.HybridSlam) on vehicle inputs and laser scans.

Subscribes (reliable, deep queues; see track_msgs_py.topics for the message mappings)

- ``/slam/inputs`` (geometry_msgs/TwistStamped): ``twist.linear.x`` = encoder speed [m/s],
  ``twist.angular.z`` = steering ANGLE [rad]; held until the next input;
- ``/slam/scan`` (sensor_msgs/PointCloud2, ``records.slam.SlamScan``: fields ``range``, ``bearing``,
  ``diameter`` after the viewers' x, y, z): one scan of tree detections. With ``add_radius``
  (default) the landmark is the trunk centre, range + diameter/2, as ``track_core.slam.victoria.load``
  does offline.

and publishes

- ``/slam/pose`` (nav_msgs/Odometry, after every scan): the laser pose with its x/y/yaw covariance;
- ``/slam/mode`` (DiagnosticArray, ``records.slam.SlamMode``, after every scan): mode and counters;
- ``/slam/events`` (DiagnosticArray, ``records.slam.SlamEvent``): one per mode switch, with the pose;
- ``/slam/particles`` (geometry_msgs/PoseArray, with headings): the particle cloud after every scan the
  PF ran on (``HybridSlam.last_particles``), including the one on which it handed back to the CEKF
  (in the PF's map frame, before the hand-over update), and an empty array at the next scan;
- ``/tf`` (map → laser, at every pose stamp and at the first input, so inputs before the first scan
  are placed too) and ``/tf_static`` (laser → base_link, the ACFR geometry
  of ``models.VehicleParams``: the laser a ahead and b left of the rear-axle centre). The tree is
  map → laser → base_link, not slam_toolbox's map → odom → base_link: the filter's state is the
  laser pose, and no node here keeps an odometry frame (raw encoder and steering inputs only).
  Scans (``laser``) and inputs (``base_link``) are placed through it, in a replay too;
- ``/slam/map`` (visualization_msgs/MarkerArray, transient-local, ``markers.slam.map_markers``):
  landmark means and 2σ ellipses, at most every ``map_period`` seconds of data time
  (``HybridSlam.map_estimate``: exact, without a copy or a global update of the filter, but
  O(n_B·n_A²) in the compressed phase, so not at every scan), and once more when the input goes idle.

Time order: inputs and scans reach the filter in stamp order through ``track_core.slam.streams.
StreamMerger`` (watermark, ``pause_wall``, ``flush_idle``, ``drain_budget``; its docstring says why), so
the result is the offline one of ``experiments.run_victoria`` (the integration test checks it on real
data). The executor does not serve the two subscriptions fairly under a backlog, so every callback
first takes all messages waiting in BOTH subscriptions (``_take_pending``): a stream the merger sees
silent has nothing queued. Deep reliable queues (``queue_depth``) and the buffer hold a backlog (nothing lost or
reordered; the output lags) and a 0.1 s steady timer keeps draining, so shutdown stays prompt.

Bad input (never raises in a callback; each goes to ``refuse``: counted per reason, logged at most
once per reason every ``warn_throttle`` seconds, on /diagnostics; and counted in ``/slam/mode``):

- an observation (one point of a scan) that ``streams.scan_observations`` finds unusable (non-finite,
  range ≤ 0 or beyond the world bound of ``validate.InputPolicy``, diameter beyond it, bearing outside
  ``hybrid.bearing_limits`` ± ``bearing_tolerance``) is dropped, the rest of the scan used. A scan
  without ``range``/``bearing`` fields, or with observations none of which is usable, is refused whole
  before its stamp reaches the merger (an empty scan, with no observation, is a valid one);
- an input with a non-finite value, |speed| beyond the policy's speed bound or |steering| ≥ π/2 is dropped;
- a message whose stamp is malformed, more than ``stamp_horizon`` (or ``stamp_lead``) ahead of the node clock (once it
  reads non-zero, ``validate.clock_now``), earlier than the previous one on its topic (time went
  backwards), or earlier than data already processed (arrived more than the buffer allows), is
  refused before it reaches the filter, so the state is untouched. A zero stamp is accepted: data
  time starts at 0 here (slam_sim's first input is stamped 0.0).

A clock jump (``track_nodes.base.timejump``: a bag replayed in a loop) starts a new run: the filter
at ``pose0`` seeded again, the stream merger and the map schedule forgotten (``reset_time_state``).

Parameters (``slam/params.py``): the node's own, then every field of the core's ``SlamParams``,
``PFParams`` and ``HybridParams`` as ``cekf.*``, ``pf.*`` and ``hybrid.*``, with the defaults of
``profile``: ``victoria_park`` or ``loop_sim`` (``track_core.slam.profiles``; the latter is the
default ``LoopWorld`` with the ambiguity trigger on, as ``slam-loop``). Invalid values stop the node.
"""

from __future__ import annotations

import math
import time

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseArray, TwistStamped
from nav_msgs.msg import Odometry
from rclpy.clock import Clock, ClockType
from rclpy.exceptions import InvalidHandle
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import PointCloud2
from visualization_msgs.msg import MarkerArray

from track_core.filters import symmetrize
from track_core.slam import HybridSlam
from track_core.slam.blas import single_threaded_blas
from track_core.slam.streams import INPUT, SCAN, StreamMerger, scan_observations
from track_msgs_py.markers.slam import map_markers
from track_msgs_py.odometry import pose_to_odometry, positions_to_pose_array, twist_to_inputs
from track_msgs_py.qos import ESTIMATE_QOS, SENSOR_QOS, STATIC_QOS
from track_msgs_py.records import RecordError
from track_msgs_py.records.slam import SlamEvent, SlamMode, SlamScan
from track_msgs_py.stamps import stamp_to_ns
from track_msgs_py.tf import frame_pair_problem, odometry_transform, planar_transform
from track_msgs_py.topics import (
    FRAME_BASE,
    SLAM_EVENTS,
    SLAM_INPUTS,
    SLAM_MAP,
    SLAM_MODE,
    SLAM_PARTICLES,
    SLAM_POSE,
    SLAM_SCAN,
)
from track_msgs_py.validate import InputPolicy, clock_now, speed_steer_problem, stamp_problem
from track_nodes.base import ParameterError, TrackNode, run_node, vector
from track_nodes.slam.params import SlamNodeParams

_TOPIC = {INPUT: SLAM_INPUTS, SCAN: SLAM_SCAN}


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
        pose0, var0 = vector('pose0', p.pose0, 3), vector('pose0_var', p.pose0_var, 3, positive=True)
        self._new_slam = lambda: HybridSlam(pose0, np.diag(var0), np.random.default_rng(p.seed), p.cekf, p.pf,
                                            p.hybrid, compressed=p.compressed)
        self.slam = self._new_slam()
        problem = frame_pair_problem(p.frame_id, p.child_frame_id) or frame_pair_problem(p.child_frame_id, FRAME_BASE)
        if problem:
            raise ParameterError(f'parameters frame_id={p.frame_id!r}, child_frame_id={p.child_frame_id!r}: {problem}')
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
        self.pub_mode = self.create_publisher(DiagnosticArray, SLAM_MODE, ESTIMATE_QOS)
        self.pub_events = self.create_publisher(DiagnosticArray, SLAM_EVENTS, ESTIMATE_QOS)
        self.pub_particles = self.create_publisher(PoseArray, SLAM_PARTICLES, SENSOR_QOS)
        self.pub_map = self.create_publisher(MarkerArray, SLAM_MAP, STATIC_QOS)
        qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=p.queue_depth,
                         reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
        self.sub_inputs = self.create_subscription(TwistStamped, SLAM_INPUTS, self._on_input, qos)
        self.sub_scan = self.create_subscription(PointCloud2, SLAM_SCAN, self._on_scan, qos)
        vehicle = self.slam.vehicle  # base_link (rear-axle centre) seen from the laser: (-a, -b), same heading
        self.add_static_transforms(planar_transform(0.0, p.child_frame_id, FRAME_BASE, -vehicle.a, -vehicle.b, 0.0))
        self.advertise_transforms()
        self.create_timer(min(0.1, p.flush_idle / 2), self._on_idle, clock=Clock(clock_type=ClockType.STEADY_TIME))

    def reset_time_state(self) -> tuple[str, ...]:
        """A new run (a clock jump): the filter at pose0 (seeded again), the stream merger, the map clock."""
        self.slam = self._new_slam()
        self.merger.reset(time.monotonic())
        self._map_ns, self._map_dirty, self._pf_published, self._n_events = None, False, False, 0
        return ('filter (at pose0, seeded again)', 'stream merger', 'map schedule')

    @property
    def processed_ns(self) -> int | None:  # stamp of the last event the filter took
        return self.merger.processed_ns

    def _on_input(self, msg: TwistStamped) -> None:
        self._add_input(msg)
        self._after_message()

    def _on_scan(self, msg: PointCloud2) -> None:
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

    def _add_input(self, msg: TwistStamped) -> None:
        self._heard[INPUT] = time.monotonic()  # refused or not, the stream is not silent (streams: pause rule)
        _, speed, steer = twist_to_inputs(msg)
        reason = speed_steer_problem(speed, steer, self.policy)
        if reason:
            self.n_bad_inputs += 1
            self.refuse(SLAM_INPUTS, reason)
            return
        self._offer(INPUT, msg.header.stamp, (speed, steer))

    def _add_scan(self, msg: PointCloud2) -> None:
        self._heard[SCAN] = time.monotonic()
        try:
            scan = SlamScan.from_msg(msg)
        except RecordError as exc:
            self.n_bad_scans += 1
            self.refuse(SLAM_SCAN, f'scan: {exc}')
            return
        limits = self.slam.params.bearing_limits
        z, ok = scan_observations(scan.range, scan.bearing, scan.diameter, limits, self.p.bearing_tolerance,
                                  self.p.add_radius, self.policy.world_bound)
        example = f'e.g. range {scan.range[~ok][0]:.4g}, bearing {scan.bearing[~ok][0]:.4g}' if not ok.all() else ''
        if ok.size and not ok.any():  # garbage, not an empty scan: refused before its stamp reaches the merger
            self.n_bad_scans += 1
            self.refuse(SLAM_SCAN, f'scan: no usable observation of {ok.size} (streams.scan_observations), {example}')
            return
        if self._offer(SCAN, msg.header.stamp, z) and not np.all(ok):
            bad = int(np.sum(~ok))
            self.n_dropped_obs += bad
            self.refuse(SLAM_SCAN, f'observations dropped: {bad} of {ok.size} at t = {scan.t:.3f} s (streams.'
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
        self.refuse(_TOPIC[stream], reason if reason.startswith('header.') else f'header.stamp: {reason}')
        return False

    # -- core step and outputs ------------------------------------------------------------------
    def _step(self, stream: str, t_ns: int, payload) -> bool:
        """One released event into the filter; False when the core refused it (state unchanged)."""
        t = t_ns / 1_000_000_000  # == stamp_to_sec: int / int is the nearest float (t_ns / 1e9 is not)
        if stream == INPUT:
            ok = self.slam.process_input(t, *payload)
            self.n_inputs += ok
            if ok and self.n_inputs == 1 and not self.n_scans:  # the tree from the data's start on
                self.send_transforms(odometry_transform(self._pose_msg(t)))
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
        for ev in s.events[self._n_events:]:
            self._publish_event(ev)
        self._n_events = len(s.events)
        pose = self._pose_msg(t)
        self.send_transforms(odometry_transform(pose))
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
        self.pub_mode.publish(mode.to_msg(t, self.get_name()))
        if self._map_ns is None or t_ns - self._map_ns >= round(p.map_period * 1e9):
            self._publish_map(t)

    def _pose_msg(self, t: float) -> Odometry:
        s, p = self.slam, self.p
        return pose_to_odometry(t, s.pose, symmetrize(s.pose_cov), p.frame_id, p.child_frame_id)

    def _publish_event(self, ev) -> None:
        x, y, yaw = (float(v) for v in self.slam.pose)
        rec = SlamEvent(ev.kind, ev.t, ev.scans, x, y, yaw)
        self.pub_events.publish(rec.to_msg(self.get_name()))
        self.get_logger().info(f't = {ev.t:.3f} s: {rec.text}' + (f' after {ev.scans} PF scans' if ev.scans else ''))

    def _publish_map(self, t: float) -> None:
        self._map_ns = round(t * 1e9)
        self._map_dirty = False
        lm, covs = self.slam.map_estimate()
        self.pub_map.publish(map_markers(t, lm, covs, self.p.frame_id, self.p.ellipse_points))
