"""``slam``: hybrid CEKF ⇄ particle-filter SLAM (track_core.slam.HybridSlam) on vehicle inputs and laser scans.

Subscribes (reliable, deep queues; see track_msgs_py.topics for the message mappings)

- ``/slam/inputs`` (geometry_msgs/TwistStamped): ``twist.linear.x`` = encoder speed [m/s],
  ``twist.angular.z`` = steering ANGLE [rad]; held until the next input;
- ``/slam/scan`` (sensor_msgs/PointCloud2, fields ``range``, ``bearing``, ``diameter``): one scan of
  tree detections. With ``add_radius`` (default) the landmark is the trunk centre, range + diameter/2,
  as ``track_core.slam.victoria.load`` does offline.

and publishes

- ``/slam/pose`` (nav_msgs/Odometry, after every scan): the laser pose with its x/y/yaw covariance;
- ``/slam/mode`` (diagnostic_msgs/DiagnosticArray, after every scan): CEKF or PF and counters;
- ``/slam/events`` (DiagnosticArray): one message per mode switch (CEKF → PF, PF → CEKF or PF timeout),
  with the pose after the scan of the switch;
- ``/slam/particles`` (geometry_msgs/PoseArray, with headings): the particle cloud after every scan the
  PF ran on (``HybridSlam.last_particles``), including the one on which it converged and handed back
  to the CEKF (so an episode that starts and converges within one scan is shown too; that last cloud
  is in the map frame the PF used, before the hand-over update), and an empty array at the first
  scan after the episode;
- ``/slam/map`` (visualization_msgs/MarkerArray, transient-local): landmark means and 2σ ellipses, at
  most every ``map_period`` seconds of data time (``HybridSlam.map_estimate``: exact, without a copy
  or a global update of the filter, but O(n_B·n_A²) in the compressed phase, so not at every scan),
  and once more when the input goes idle.

Time order. The filter must see inputs and scans in stamp order (an input predicts from its stamp,
a scan updates at its stamp), but the two topics arrive on separate subscriptions and the executor
takes one message per ready subscription per round, so with a backlog the (8× rarer) scans run
ahead of the inputs that precede them. Messages are therefore held in a buffer and processed in
stamp order (at equal stamps the scan first, as ``victoria.events``) up to the *watermark*: the
older of the last input stamp and the last scan stamp received. Each topic is monotonic on its own
(enforced, see below), so nothing older than the watermark can still come. A stream that pauses
(no trees in view; no scan publisher at all) must not stall the filter: it is left out of the
watermark once it has been silent for ``pause_wall`` wall seconds *and* the other stream has
delivered at least two messages meanwhile. That is sound only if "silent" means "nothing queued":
the executor does not serve the two subscriptions fairly under a backlog (a replay of Victoria
Park at 5x had scans processed 300 s of data ahead of their inputs), so every callback first takes
all messages waiting in BOTH subscriptions into the buffer (``_take_pending``); a node that was
busy in a long callback sees every stream silent but then finds their queues full, and waits. Everything buffered is
processed when no message has been handled for ``flush_idle`` wall seconds (the end of a bag),
counted from the end of the last message callback so that a node busy with a long update is not
idle. The processing order, and so the result, is the offline one of
``track_core.slam.experiments.run_victoria`` (the integration test checks this on real data).
Processing keeps up when the core is faster than the replay; when it is not, the deep reliable
queues (``queue_depth``) and the buffer hold the backlog and nothing is lost or reordered, the output
just lags. One callback spends at most ``drain_budget`` on buffered events (the next callbacks and a
0.1 s timer continue), so a backlog never blocks the executor for long (shutdown stays prompt).

Bad input (never raises in a callback; each kind logs through its own throttled warning,
``throttle_duration_sec = warn_throttle``, and is counted in ``/slam/mode``):

- an observation (one point of a scan) with a non-finite range, bearing or diameter, a range ≤ 0,
  or a bearing outside ``hybrid.bearing_limits`` (default [0, π]) is dropped; the rest of the scan
  is used. Bearings within ``bearing_tolerance`` outside the limits are clipped into them (float32
  rounding puts π at 3.1415927 > π). A scan without ``range``/``bearing`` fields is dropped whole;
- an input with a non-finite value or |steering| ≥ π/2 is dropped;
- a message whose stamp is earlier than the previous one on its topic (time went backwards), or
  earlier than data already processed (arrived more than the buffer allows), is refused before it
  reaches the filter, so the state is untouched.

Parameters: the node's own (below), then every field of the core's ``SlamParams`` as ``cekf.<field>``,
of ``PFParams`` as ``pf.<field>`` and of ``HybridParams`` as ``hybrid.<field>``, whose defaults come
from ``profile``: ``victoria_park`` (the core's Victoria Park settings, ``experiments.VP_SLAM``/
``VP_PF``) or ``loop_sim`` (``experiments.loop_params`` of the default ``LoopWorld`` with the
ambiguity trigger, as the ``slam-loop`` experiment). Invalid values stop the node with one line.
"""

from __future__ import annotations

import heapq
import math
import time
from types import SimpleNamespace

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import Point, PoseArray, TwistStamped
from nav_msgs.msg import Odometry
from rclpy.clock import Clock, ClockType
from rclpy.exceptions import InvalidHandle
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import ColorRGBA, Header
from visualization_msgs.msg import Marker, MarkerArray

from track_core.filters import ellipse_points, symmetrize
from track_core.slam import HybridParams, HybridSlam, PFParams, SlamParams, valid_observations
from track_core.slam.blas import single_threaded_blas
from track_msgs_py.convert import (
    DIAG_OK,
    DIAG_WARN,
    diagnostic_array,
    diagnostic_status,
    pointcloud2_to_table,
    pose_to_odometry,
    positions_to_pose_array,
    sec_to_stamp,
    stamp_to_ns,
)
from track_msgs_py.qos import ESTIMATE_QOS, SENSOR_QOS, STATIC_QOS
from track_msgs_py.topics import (
    FRAME_LASER,
    FRAME_MAP,
    SLAM_EVENTS,
    SLAM_INPUTS,
    SLAM_MAP,
    SLAM_MODE,
    SLAM_PARTICLES,
    SLAM_POSE,
    SLAM_SCAN,
)
from track_nodes.base import Param, TrackNode, declare_dataclass, declare_params, run_node, vector


# --------------------------------------------------------------------------------------------
# Parameters
# --------------------------------------------------------------------------------------------
def _profile_victoria_park():
    from track_core.slam import experiments

    return SimpleNamespace(slam=experiments.VP_SLAM, pf=experiments.VP_PF, hybrid=HybridParams(),
                           pose0=[0.0, 0.0, 0.0])


def _profile_loop_sim():
    from track_core.slam import experiments
    from track_core.slam.sim import LoopWorld

    w = LoopWorld()
    sp, pp = experiments.loop_params(w)
    return SimpleNamespace(slam=sp, pf=pp, hybrid=HybridParams(trigger_on_ambiguity=True),
                           pose0=[float(v) for v in w.start()])


PROFILES = {'victoria_park': _profile_victoria_park, 'loop_sim': _profile_loop_sim}
CORE_GROUPS = (('cekf', SlamParams, 'slam'), ('pf', PFParams, 'pf'), ('hybrid', HybridParams, 'hybrid'))

PROFILE_PARAM = Param('profile', 'victoria_park', 'defaults of the cekf.*, pf.*, hybrid.* and pose0 parameters',
                      choices=tuple(PROFILES))


def node_params(pose0: list[float]) -> tuple[Param, ...]:
    return (
        Param('seed', 0, 'seed of the particle filter Generator', 0, 2**31 - 1),
        Param('pose0', pose0, 'initial laser pose [x m, y m, heading rad] in map'),
        Param('pose0_var', [1e-6, 1e-6, 1e-6], 'initial pose variances [m², m², rad²] (all > 0)'),
        Param('compressed', True, 'Compressed EKF (false: the full EKF; same result, slower)'),
        Param('add_radius', True, 'landmark = trunk centre: range + diameter/2 (victoria.load add_radius)'),
        Param('bearing_tolerance', 1e-6, 'bearings this far outside hybrid.bearing_limits are clipped, not '
              'dropped (float32 rounding) [rad]', 0.0, 0.1),
        Param('pause_wall', 0.2, 'a stream silent this long (wall) while the other delivered >= 2 messages no '
              'longer holds the other back [s]', 0.0, 60.0),
        Param('flush_idle', 0.5, 'process everything buffered after this long without a message (wall) [s]',
              0.01, 60.0),
        Param('drain_budget', 0.2, 'wall time one callback may spend on buffered events; the rest follows in the '
              'next callbacks (keeps the node responsive, e.g. to shutdown, during a backlog) [s]', 0.001, 60.0),
        Param('queue_depth', 100000, 'depth of the reliable input and scan subscriptions', 10, 1_000_000),
        Param('map_period', 2.0, 'publish the map at most every this much data time [s]; 0 = every scan',
              0.0, 3600.0),
        Param('ellipse_points', 16, 'points per 2σ landmark ellipse', 4, 360),
        Param('max_particles_published', 500, 'particles per PoseArray (an even subsample)', 1, 1_000_000),
        Param('warn_throttle', 5.0, 'throttle_duration_sec of the bad-input warnings [s]', 0.0, 3600.0),
        Param('frame_id', FRAME_MAP, 'frame of the pose, map and particles'),
        Param('child_frame_id', FRAME_LASER, 'child_frame_id of the pose (the SLAM state is the laser pose)'),
    )


_SCAN, _INPUT = 0, 1  # priority at equal stamps: the scan first (victoria.events)


class SlamNode(TrackNode):
    DEFAULT_NAME = 'slam'

    @classmethod
    def main(cls, argv=None, **kwargs) -> int:
        # One BLAS thread for the whole process: the CEKF's small products otherwise spin OpenBLAS
        # workers on a busy machine (track_core/slam/blas.py measures 10x and more).
        with single_threaded_blas():
            return run_node(cls, argv, **kwargs)

    def __init__(self, **kw) -> None:
        super().__init__(**kw)
        profile = PROFILES[declare_params(self, [PROFILE_PARAM]).profile]()
        self.p = p = declare_params(self, node_params(profile.pose0))
        cores = {attr: declare_dataclass(self, prefix, getattr(profile, attr)) for prefix, _, attr in CORE_GROUPS}
        pose0 = vector('pose0', p.pose0, 3)
        var0 = vector('pose0_var', p.pose0_var, 3, positive=True)
        self.hybrid_params: HybridParams = cores['hybrid']
        self.slam = HybridSlam(pose0, np.diag(var0), np.random.default_rng(p.seed), cores['slam'], cores['pf'],
                               cores['hybrid'], compressed=p.compressed)
        # buffer and bookkeeping (stamps as integer nanoseconds: exact comparisons)
        self._heap: list = []
        self._seq = 0
        self._last_ns: dict[str, int | None] = {SLAM_INPUTS: None, SLAM_SCAN: None}  # last accepted stamp
        self._arrival: dict[str, float | None] = {SLAM_INPUTS: None, SLAM_SCAN: None}  # its wall time
        self._count = {SLAM_INPUTS: 0, SLAM_SCAN: 0}  # messages accepted per stream
        self._other_at = {SLAM_INPUTS: 0, SLAM_SCAN: 0}  # the other stream's count at this one's last message
        self._first_arrival: float | None = None
        self.processed_ns: int | None = None
        self._last_activity = time.monotonic()  # end of the last subscription callback (wall)
        self._map_ns: int | None = None
        self._map_dirty = False
        self._n_events = 0
        self._pf_published = False
        self.n_inputs = self.n_scans = 0
        self.n_dropped_obs = self.n_bad_inputs = self.n_bad_scans = self.n_refused = 0
        # publishers and subscriptions
        self.pub_pose = self.create_publisher(Odometry, SLAM_POSE, ESTIMATE_QOS)
        self.pub_mode = self.create_publisher(DiagnosticArray, SLAM_MODE, ESTIMATE_QOS)
        self.pub_events = self.create_publisher(DiagnosticArray, SLAM_EVENTS, ESTIMATE_QOS)
        self.pub_particles = self.create_publisher(PoseArray, SLAM_PARTICLES, SENSOR_QOS)
        self.pub_map = self.create_publisher(MarkerArray, SLAM_MAP, STATIC_QOS)
        qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=p.queue_depth,
                         reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
        self.sub_inputs = self.create_subscription(TwistStamped, SLAM_INPUTS, self._on_input, qos)
        self.sub_scan = self.create_subscription(PointCloud2, SLAM_SCAN, self._on_scan, qos)
        self.create_timer(min(0.1, p.flush_idle / 2), self._on_idle, clock=Clock(clock_type=ClockType.STEADY_TIME))

    # -- input callbacks ------------------------------------------------------------------------
    def _on_input(self, msg: TwistStamped) -> None:
        self._add_input(msg)
        self._after_message()

    def _on_scan(self, msg: PointCloud2) -> None:
        self._add_scan(msg)
        self._after_message()

    def _after_message(self) -> None:
        self._take_pending()
        self._drain(self._watermark(time.monotonic()))
        self._last_activity = time.monotonic()

    def _take_pending(self) -> int:
        """Take every message already waiting in both subscriptions into the buffer.

        The executor's order of serving the two subscriptions is not fair under a backlog (its pool
        threads race for the node's callback group), so the callbacks themselves empty both queues:
        the watermark then sees everything that has arrived, and a silent stream really has nothing
        queued. Uses the take the executor itself uses (``handle.take_message``); if that is not
        available the node falls back to the executor's order. Returns the number of messages taken.
        """
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
        speed, steer = float(msg.twist.linear.x), float(msg.twist.angular.z)
        if not (math.isfinite(speed) and math.isfinite(steer) and abs(steer) < math.pi / 2):
            self.n_bad_inputs += 1
            self.get_logger().warning(f'{SLAM_INPUTS}: input dropped: speed {speed}, steering {steer} (need finite '
                                      f'values, |steering| < π/2); {self.n_bad_inputs} so far',
                                      throttle_duration_sec=self.p.warn_throttle)
            return
        t_ns = self._accept(SLAM_INPUTS, msg.header.stamp)
        if t_ns is not None:
            self._push(SLAM_INPUTS, t_ns, _INPUT, (speed, steer))

    def _add_scan(self, msg: PointCloud2) -> None:
        try:
            table = pointcloud2_to_table(msg)
            r, b = table['range'], table['bearing']
            d = table.get('diameter', np.zeros_like(r))
            if r.ndim != 1 or b.ndim != 1 or d.ndim != 1:
                raise ValueError('range, bearing and diameter must have count 1')
        except (KeyError, ValueError) as exc:
            self.n_bad_scans += 1
            self.get_logger().warning(f'{SLAM_SCAN}: scan dropped: needs float fields range and bearing '
                                      f'({type(exc).__name__}: {exc}); {self.n_bad_scans} so far',
                                      throttle_duration_sec=self.p.warn_throttle)
            return
        t_ns = self._accept(SLAM_SCAN, msg.header.stamp)
        if t_ns is None:
            return
        lo, hi = self.hybrid_params.bearing_limits
        tol = self.p.bearing_tolerance
        ok = valid_observations(np.stack([r, b], axis=1), (lo - tol, hi + tol))  # the core's rule, widened by tol
        if self.p.add_radius:
            ok &= np.isfinite(d) & (d >= 0)
        if not np.all(ok):
            bad = int(np.sum(~ok))
            self.n_dropped_obs += bad
            self.get_logger().warning(
                f'{SLAM_SCAN}: {bad} of {ok.size} observations dropped at t = {t_ns * 1e-9:.3f} s (need finite '
                f'values, range > 0, bearing in [{lo:.4g}, {hi:.4g}] rad): e.g. range {r[~ok][0]:.4g}, bearing '
                f'{b[~ok][0]:.4g}; {self.n_dropped_obs} so far', throttle_duration_sec=self.p.warn_throttle)
        rng = r[ok] + (0.5 * d[ok] if self.p.add_radius else 0.0)
        self._push(SLAM_SCAN, t_ns, _SCAN, np.stack([rng, np.clip(b[ok], lo, hi)], axis=1))

    def _accept(self, topic: str, stamp) -> int | None:
        """The stamp in ns, or None (refused, warned) when it goes backwards or comes too late."""
        t_ns = stamp_to_ns(stamp)
        last = self._last_ns[topic]
        if not 0 <= stamp.nanosec < 1_000_000_000:
            reason = f'malformed stamp (nanosec {stamp.nanosec})'
        elif last is not None and t_ns < last:
            reason = f'stamp {t_ns * 1e-9:.9f} s is before the previous one {last * 1e-9:.9f} s (time went backwards)'
        elif self.processed_ns is not None and t_ns < self.processed_ns:
            reason = (f'stamp {t_ns * 1e-9:.9f} s arrived after data up to {self.processed_ns * 1e-9:.9f} s was '
                      'processed')
        else:
            self._last_ns[topic] = t_ns
            return t_ns
        self.n_refused += 1
        self.get_logger().warning(f'{topic}: message refused, filter state unchanged: {reason}; '
                                  f'{self.n_refused} refused so far', throttle_duration_sec=self.p.warn_throttle)
        return None

    # -- ordering -------------------------------------------------------------------------------
    def _push(self, topic: str, t_ns: int, kind: int, payload) -> None:
        heapq.heappush(self._heap, (t_ns, kind, self._seq, payload))
        self._seq += 1
        now = time.monotonic()
        other = SLAM_SCAN if topic == SLAM_INPUTS else SLAM_INPUTS
        self._count[topic] += 1
        self._other_at[topic] = self._count[other]
        self._arrival[topic] = now
        if self._first_arrival is None:
            self._first_arrival = now

    def _watermark(self, now: float) -> int | None:
        """Stamp up to which nothing can still arrive (see the module docstring); None: wait."""
        limits = []
        for topic, other in ((SLAM_INPUTS, SLAM_SCAN), (SLAM_SCAN, SLAM_INPUTS)):
            since = self._arrival[topic] if self._arrival[topic] is not None else self._first_arrival
            paused = (since is not None and now - since >= self.p.pause_wall
                      and self._count[other] - self._other_at[topic] >= 2)
            if paused:
                continue
            if self._last_ns[topic] is None:
                return None  # not heard from yet, and not known to be absent
            limits.append(self._last_ns[topic])
        return min(limits) if limits else None

    def _drain(self, limit_ns: int | None) -> None:
        """Process buffered events with stamp ≤ limit_ns (all when None), in (stamp, scan first) order, for at
        most ``drain_budget`` wall seconds; later callbacks (and the idle timer) continue where it stopped."""
        heap = self._heap
        deadline = time.monotonic() + self.p.drain_budget
        while heap and (limit_ns is None or heap[0][0] <= limit_ns) and time.monotonic() < deadline:
            t_ns, kind, _, payload = heapq.heappop(heap)
            t = t_ns / 1e9  # == stamp_to_sec: the float nearest to the stamp
            if kind == _INPUT:
                ok = self.slam.process_input(t, *payload)
                self.n_inputs += ok
            else:
                ok = self.slam.process_scan(t, payload)
                self.n_scans += ok
            if not ok:  # the node's own checks should make this unreachable; the core refused, state unchanged
                self.n_refused += 1
                continue
            self.processed_ns = t_ns
            if kind == _SCAN:
                self._after_scan(t, t_ns)

    def _on_idle(self) -> None:
        now = time.monotonic()
        if self._take_pending():
            self._last_activity = now
        idle = now - self._last_activity >= self.p.flush_idle  # since a callback ENDED: a busy node is not idle
        if self._heap:
            self._drain(None if idle else self._watermark(now))
        if self._map_dirty and idle and not self._heap:
            self._publish_map(self.processed_ns / 1e9)

    # -- outputs --------------------------------------------------------------------------------
    def _after_scan(self, t: float, t_ns: int) -> None:
        s, p = self.slam, self.p
        self._map_dirty = True
        for ev in s.events[self._n_events:]:
            self._publish_event(ev)
        self._n_events = len(s.events)
        self.pub_pose.publish(pose_to_odometry(t, s.pose, symmetrize(s.pose_cov), p.frame_id, p.child_frame_id))
        pf_step = s.last_particles
        if pf_step is not None and pf_step.scan == s.n_scans:  # the PF ran on this scan (maybe its last)
            parts = pf_step.particles
            step = max(1, math.ceil(len(parts) / p.max_particles_published))
            parts = parts[::step]
            self.pub_particles.publish(positions_to_pose_array(t, parts[:, :2], p.frame_id, headings=parts[:, 2]))
            self._pf_published = True
        elif self._pf_published:
            self.pub_particles.publish(positions_to_pose_array(t, np.zeros((0, 2)), p.frame_id))
            self._pf_published = False
        pf_scans = s.ctx.pf.n_scans if s.mode == 'PF' and s.ctx is not None else 0
        values = {'mode': s.mode, 'scans': self.n_scans, 'inputs': self.n_inputs, 'landmarks': len(s.landmarks()),
                  'pf_switches': sum(e.kind == 'to_pf' for e in s.events), 'pf_scans': pf_scans,
                  'dropped_observations': self.n_dropped_obs, 'refused_messages': self.n_refused,
                  'bad_inputs': self.n_bad_inputs, 'bad_scans': self.n_bad_scans}
        self.pub_mode.publish(diagnostic_array(t, [diagnostic_status(f'{self.get_name()}/mode', DIAG_OK, s.mode,
                                                                     values)]))
        if self._map_ns is None or t_ns - self._map_ns >= round(p.map_period * 1e9):
            self._publish_map(t)

    def _publish_event(self, ev) -> None:
        text = {'to_pf': 'CEKF -> PF', 'to_cekf': 'PF -> CEKF', 'pf_timeout': 'PF -> CEKF (timeout)'}.get(
            ev.kind, ev.kind)
        pose = self.slam.pose
        level = DIAG_OK if ev.kind == 'to_cekf' else DIAG_WARN
        values = {'event': ev.kind, 't': ev.t, 'pf_scans': ev.scans, 'x': float(pose[0]), 'y': float(pose[1]),
                  'yaw': float(pose[2])}
        self.pub_events.publish(diagnostic_array(ev.t, [diagnostic_status(
            f'{self.get_name()}/mode_switch', level, text, values)]))
        self.get_logger().info(f't = {ev.t:.3f} s: {text}' + (f' after {ev.scans} PF scans' if ev.scans else ''))

    def _publish_map(self, t: float) -> None:
        self._map_ns = round(t * 1e9)
        self._map_dirty = False
        lm, covs = self.slam.map_estimate()
        self.pub_map.publish(map_markers(t, lm, covs, self.p.frame_id, self.p.ellipse_points))


def map_markers(t: float, lm: np.ndarray, covs: np.ndarray, frame_id: str = FRAME_MAP,
                n_points: int = 24) -> MarkerArray:
    """The /slam/map message: DELETEALL, the means as one SPHERE_LIST (ns ``slam_landmarks``, id 0) and one
    LINE_STRIP 2σ ellipse per landmark (ns ``slam_ellipses``, id = landmark index), like
    ``convert.covariance_ellipse_marker`` but built for the whole map at once."""
    header = Header(stamp=sec_to_stamp(t), frame_id=frame_id)
    markers = [Marker(header=header, action=Marker.DELETEALL)]
    means = Marker(header=header, ns='slam_landmarks', id=0, type=Marker.SPHERE_LIST, action=Marker.ADD,
                   color=ColorRGBA(r=0.1, g=0.6, b=0.1, a=1.0))
    means.pose.orientation.w = 1.0
    means.scale.x = means.scale.y = means.scale.z = 0.5
    means.points = [Point(x=x, y=y) for x, y in np.asarray(lm, dtype=float).reshape(-1, 2).tolist()]
    markers.append(means)
    if len(lm):
        pts = ellipse_points(np.asarray(lm, dtype=float), np.asarray(covs, dtype=float), 2.0, n_points)
        color = ColorRGBA(r=0.1, g=0.4, b=1.0, a=1.0)
        for i, loop in enumerate(pts.tolist()):
            m = Marker(header=header, ns='slam_ellipses', id=i, type=Marker.LINE_STRIP, action=Marker.ADD,
                       color=color)
            m.pose.orientation.w = 1.0
            m.scale.x = 0.1
            m.points = [Point(x=x, y=y) for x, y in loop]
            markers.append(m)
    return MarkerArray(markers=markers)
