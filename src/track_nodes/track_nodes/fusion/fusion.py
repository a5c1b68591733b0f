"""``fusion``: geofeasibility scoring and track-to-track association of every pair of tracks.

Inputs, each validated (finite, symmetric PSD covariance, known frame, non-decreasing stamp per
track, ``InputPolicy`` bounds, ``stamp_horizon``/``stamp_lead``); a bad one is refused with one
throttled line per reason, counted on /diagnostics, state untouched: ``track_array_topics``
(TrackArray, track id ``<topic>/<track.id>``; a bad track refused alone), ``odometry_topics`` (track
id ``<topic>/<child_frame_id>``, REP-105), ``pose_topics`` (one track a topic),
``pose_track_topics`` (local id in ``header.frame_id`` as ``"<frame>#<local id>"``) and
``navsatfix_topics`` (placed in ``map`` through the datum latched on ``map_datum``; refused without
a datum or a covariance).

Every input is scored in ``world_frame`` (``map``), moved there at its stamp through ``/tf`` and
``/tf_static`` (``track_msgs_py.tf_buffer``; refused when its frame is off the tree or the transform
is older than ``tf_tolerance``). Same-source pairs only with ``same_source_pairs``; velocities with
``not_estimated`` variance are ignored. Schedule ``timer``: score every tick of a ``rate`` Hz timer;
``stamps``: score t_k = k/``rate`` once every input has a report stamped ≥ t_k + 1/``rate`` (or
``stamps_max_wait`` passed; ``track_core.fusion.StampSchedule``), so a replayed bag reproduces every
score. ``track_core.fusion.PairAssociator`` predicts each track to the instant, scores the gate's
candidates with ``method`` (eqs. 49–71), combines the last ``window`` instants (§1) and fuses the
associated pairs by covariance intersection.

Outputs: ``/fusion/scores`` and ``/fusion/associations`` (PairScoreArray; ``publish_pairs``:
``nonzero`` or ``all``; ``threshold``, ``release_ratio``), ``/fusion/fused`` (FusedTrackArray),
``/fusion/markers`` (2σ ellipses and links at ``display_rate``). Shards (``region``,
``region_margin``): keep the tracks within the margin, publish the pairs whose midpoint is inside.
In full: docs/MODULES.md, "The fusion node in full".
"""

from __future__ import annotations

import numpy as np
from geometry_msgs.msg import PoseWithCovarianceStamped
from nav_msgs.msg import Odometry
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import NavSatFix
from visualization_msgs.msg import MarkerArray

from track_core.fusion import Instant, PairAssociator, TrackReport
from track_core.fusion.region import Region, ShardInput
from track_msgs.msg import FusedTrackArray, PairScoreArray, TrackArray
from track_msgs_py.ais import navsatfix_position_problem, navsatfix_to_position
from track_msgs_py.covariance import not_estimated
from track_msgs_py.markers.fusion import FusionMarkers
from track_msgs_py.odometry import odometry_to_cv_state, pose_cov_to_position
from track_msgs_py.qos import ESTIMATE_QOS
from track_msgs_py.records.fusion import FusedTracks, FusionPairs
from track_msgs_py.stamps import stamp_to_sec
from track_msgs_py.tf import TF, TF_QOS, TF_STATIC, TF_STATIC_QOS, frame_id_problem
from track_msgs_py.tf_buffer import TransformBuffer, move_cv_states
from track_msgs_py.topics import (
    FUSION_ASSOCIATIONS,
    FUSION_FUSED,
    FUSION_MARKERS,
    FUSION_SCORES,
    split_track_frame_id,
)
from track_msgs_py.track_arrays import array_to_tracks, position_tracks, track_problems
from track_msgs_py.validate import (
    InputPolicy,
    StampMonotonic,
    bound_problem,
    clock_now,
    odometry_bounds_problem,
    odometry_problem,
    pose_cov_bounds_problem,
    pose_cov_problem,
    stamp_problem,
)
from track_nodes.base import ParameterError, TrackNode
from track_nodes.fusion.map_datum import MapDatumLink
from track_nodes.fusion.params import FusionParams, associator_config

# Best effort accepts both reliable and best-effort publishers; depth covers a few rate periods.
TRACK_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=50, reliability=ReliabilityPolicy.BEST_EFFORT)
# Topics carrying many tracks (pose_track_topics): one burst per instant holds every ship of a source.
TRACKS_QOS_DEPTH = 1000
TRACKS_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=TRACKS_QOS_DEPTH,
                        reliability=ReliabilityPolicy.BEST_EFFORT)
# A TrackArray is a whole source's tick (hundreds of kB at 5000 tracks): reliable, or one lost
# fragment loses the tick for every track of the source. Its publishers must be reliable too.
ARRAY_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10, reliability=ReliabilityPolicy.RELIABLE)


class FusionNode(TrackNode):
    DEFAULT_NAME = 'fusion'
    Params = FusionParams
    p: FusionParams  # the declared parameters (base/params.py)

    def setup(self) -> None:
        p = self.p
        arrays, odo, pose, multi, fixes = ([t for t in ts if t] for ts in (
            p.track_array_topics, p.odometry_topics, p.pose_topics, p.pose_track_topics, p.navsatfix_topics))
        if not (arrays or odo or pose or multi or fixes):
            raise ParameterError('parameters track_array_topics, odometry_topics, pose_topics, pose_track_topics and '
                                 'navsatfix_topics are all empty: nothing to fuse')
        try:
            self.region = Region.parse(p.region, p.region_margin)
        except ValueError as exc:
            raise ParameterError(f'parameter region: {exc}') from None
        self.shard = ShardInput(self.region)
        streams = tuple(self.resolve_topic_name(t) for t in (*arrays, *odo, *pose, *multi, *fixes))
        self.core = PairAssociator(associator_config(p), stamp_streams=streams)
        self.markers = FusionMarkers(lifetime=2.0 / min(p.rate, p.display_rate))
        self.stamps = StampMonotonic()
        self.policy = InputPolicy(horizon=p.stamp_horizon, lead=p.stamp_lead)
        self.refusals.throttle = p.warn_period
        self.dropped: dict[str, int] = {}
        self._displayed: float | None = None   # instant of the last markers
        # The track topics are the user's names, as given: relative ones resolve in the node's namespace.
        # Track ids use the resolved name (track_id = <resolved topic>/<id>), the same in any namespace form.
        self.subs = [self._track_sub(TrackArray, t, '_on_track_array', ARRAY_QOS) for t in arrays]
        self.subs += [self._track_sub(Odometry, t, '_on_odometry', TRACK_QOS) for t in odo]
        self.subs += [self._track_sub(PoseWithCovarianceStamped, t, '_on_pose', TRACK_QOS) for t in pose]
        self.subs += [self._track_sub(PoseWithCovarianceStamped, t, '_on_pose_track', TRACKS_QOS) for t in multi]
        self.map_datum = MapDatumLink(self, publish=False) if fixes else None
        self.subs += [self._track_sub(NavSatFix, t, '_on_navsatfix', TRACK_QOS) for t in fixes]
        self.pub_scores = self.create_publisher(PairScoreArray, FUSION_SCORES, ESTIMATE_QOS)
        self.pub_assoc = self.create_publisher(PairScoreArray, FUSION_ASSOCIATIONS, ESTIMATE_QOS)
        self.pub_fused = self.create_publisher(FusedTrackArray, FUSION_FUSED, ESTIMATE_QOS)
        self.pub_markers = self.create_publisher(MarkerArray, FUSION_MARKERS, ESTIMATE_QOS)
        self.timer = self.create_timer(1.0 / p.rate, self.tick) if p.schedule == 'timer' else None
        self.tf = TransformBuffer(history=p.tf_history, tolerance=p.tf_tolerance)
        from tf2_msgs.msg import TFMessage

        self.sub_tf = self.create_subscription(TFMessage, TF, lambda m: self._on_tf(TF, m, False), TF_QOS)
        self.sub_tf_static = self.create_subscription(TFMessage, TF_STATIC, lambda m: self._on_tf(TF_STATIC, m, True),
                                                      TF_STATIC_QOS)

    def _track_sub(self, cls, topic: str, handler: str, qos):
        """A track topic's subscription; the handler is looked up at call time (tests wrap it)."""
        name = self.resolve_topic_name(topic)
        return self.create_subscription(cls, topic, lambda m: getattr(self, handler)(name, m), qos, as_given=True)

    def validate_params(self, p) -> None:
        if p.schedule == 'stamps' and p.rate != self.p.rate:
            raise ParameterError('parameter rate is fixed with schedule=stamps (it sets the scoring instants k/rate)')
        associator_config(p)

    def apply_params(self, changed: set[str]) -> None:
        p = self.p
        self.core.tune(associator_config(p))
        self.refusals.throttle = float(p.warn_period)
        self.policy = InputPolicy(horizon=p.stamp_horizon, lead=p.stamp_lead)
        if 'rate' in changed and self.timer is not None:
            self.timer.timer_period_ns = round(1e9 / p.rate)
        self.markers.lifetime = 2.0 / min(p.rate, p.display_rate)
        self.tf.tolerance = float(p.tf_tolerance)

    def reset_time_state(self) -> tuple[str, ...]:
        self.core.reset()
        self.stamps.reset()
        self.shard.clear()
        self._displayed = None
        self.tf.clear()
        return ('tracks', 'pair windows', 'stamp schedule', 'stamp watermarks', 'transform buffer')

    @property
    def next_k(self) -> int | None:
        """schedule stamps: index of the next instant k/rate to score (None before the first report)."""
        return None if self.core.schedule is None else self.core.schedule.next_k

    # -- input ---------------------------------------------------------------------------
    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def _drop(self, topic: str, reason: str) -> None:
        self.dropped[topic] = self.dropped.get(topic, 0) + 1
        self.refuse(topic, reason)

    def _stamp_problem(self, msg) -> str | None:
        return stamp_problem(stamp_to_sec(msg.header.stamp), clock_now(self.get_clock().now().nanoseconds), self.policy)

    def _on_tf(self, topic: str, msg, static: bool) -> None:
        for reason in self.tf.add(msg, static):
            self.refuse(topic, reason)

    def _to_world(self, frame: str, t: float, x: np.ndarray, P: np.ndarray):
        """CV states (n, 4) and covariances in ``frame`` at ``t`` → in the world frame, or a reason."""
        world = self.p.world_frame
        if frame == world:
            return x, P, None
        reason = frame_id_problem(frame, 'header.frame_id')
        T = None
        if reason is None:
            T, reason = self.tf.lookup(world, frame, t)
        if reason is not None:
            return None, None, reason
        x, P = move_cv_states(T, x, P, self.tf.motion(world, frame, t))
        return x, P, None

    def _on_track_array(self, topic: str, msg: TrackArray) -> None:
        reason = self._stamp_problem(msg)
        if reason:
            self._drop(topic, reason)
            return
        t, ids, _, x, P = array_to_tracks(msg)
        bad = track_problems(ids, x, P, self.policy)
        if msg.header.frame_id != self.p.world_frame:
            ok = np.array([k not in bad for k in range(len(ids))], dtype=bool)
            x, P = x.copy(), P.copy()
            moved_x, moved_P, reason = self._to_world(msg.header.frame_id, t, x[ok], P[ok])
            if reason:
                self._drop(topic, reason)
                return
            x[ok], P[ok] = moved_x, moved_P
        inside = self.region.contains_all(x[:, 0], x[:, 2])
        held = self.shard.held
        for k, local in enumerate(ids):
            track_id = f'{topic}/{local}'
            if not inside[k] and k not in bad and track_id not in held:   # another shard's track: skip it fast
                self.shard.outside += 1
                continue
            reason = bad.get(k) or self.stamps.problem(track_id, t)
            if reason:
                self._drop(topic, reason)
            else:
                self._push_state(topic, track_id, t, x[k], P[k], topic)
        for instant in self.core.heard(topic, t):   # its watermark, also when every track was another shard's
            self._publish(instant)

    def _on_odometry(self, topic: str, msg: Odometry) -> None:
        track_id = f'{topic}/{msg.child_frame_id}' if msg.child_frame_id else topic
        reason = (odometry_problem(msg, None) or odometry_bounds_problem(msg, self.policy)
                  or self._stamp_problem(msg) or self.stamps.msg_problem(track_id, msg))
        t, x, P = odometry_to_cv_state(msg) if not reason else (0.0, None, None)
        if not reason:
            x, P, reason = self._to_world(msg.header.frame_id, t, x[None], P[None])
        if reason:
            self._drop(topic, reason)
            return
        self._push_state(topic, track_id, t, x[0], P[0], topic)

    def _push_state(self, source: str, track_id: str, t: float, x: np.ndarray, P: np.ndarray, stream: str) -> None:
        """A CV state [x, ẋ, y, ẏ] and its covariance: held as a position when the velocity is not estimated."""
        Pv = P[np.ix_([1, 3], [1, 3])]
        if np.any(not_estimated(np.diag(Pv))):
            self._push(source, track_id, TrackReport(t, x[[0, 2]], P[np.ix_([0, 2], [0, 2])]), stream)
            return
        self._push(source, track_id, TrackReport(t, x[[0, 2]], P[np.ix_([0, 2], [0, 2])], x[[1, 3]], Pv), stream)

    def _on_pose(self, topic: str, msg: PoseWithCovarianceStamped) -> None:
        reason = (pose_cov_problem(msg, None) or pose_cov_bounds_problem(msg, self.policy)
                  or self._stamp_problem(msg) or self.stamps.msg_problem(topic, msg))
        if not reason:
            t, z, R = pose_cov_to_position(msg)
            z, R, reason = self._position_to_world(msg.header.frame_id, t, z, R)
        if reason:
            self._drop(topic, reason)
            return
        # One track per topic; a source publishes its tracks under one namespace (<source>/<track>).
        self._push(topic.rsplit('/', 1)[0] or topic, topic, TrackReport(t, z, R), topic)

    def _on_pose_track(self, topic: str, msg: PoseWithCovarianceStamped) -> None:
        frame, local = split_track_frame_id(msg.header.frame_id)
        if not local:
            self._drop(topic, f'header.frame_id: {msg.header.frame_id!r} carries no track id '
                              '(expected "<frame>#<local id>")')
            return
        track_id = f'{topic}/{local}'
        reason = (pose_cov_problem(msg, None) or pose_cov_bounds_problem(msg, self.policy)
                  or self._stamp_problem(msg) or self.stamps.msg_problem(track_id, msg))
        if not reason:
            t, z, R = pose_cov_to_position(msg)
            z, R, reason = self._position_to_world(frame, t, z, R)
        if reason:
            self._drop(topic, reason)
            return
        self._push(topic, track_id, TrackReport(t, z, R), topic)  # the topic is the source

    def _on_navsatfix(self, topic: str, msg: NavSatFix) -> None:
        reason = (navsatfix_position_problem(msg, self.policy) or self._stamp_problem(msg)
                  or self.map_datum.problem())
        if not reason:
            t, z, R = navsatfix_to_position(msg, self.map_datum.datum)
            reason = bound_problem('latitude/longitude in map', self.policy.world_bound, x=z[0], y=z[1])
        if not reason:
            z, R, reason = self._position_to_world(self.map_datum.frame_id, t, z, R)
        reason = reason or self.stamps.msg_problem(topic, msg)   # last: only a usable fix moves the watermark
        if reason:
            self._drop(topic, reason)
            return
        self._push(topic.rsplit('/', 1)[0] or topic, topic, TrackReport(t, z, R), topic)

    def _position_to_world(self, frame: str, t: float, z: np.ndarray, R: np.ndarray):
        """A position report in ``frame`` → the world frame (position and covariance), or a reason."""
        x, P = position_tracks(z, R)
        x, P, reason = self._to_world(frame, t, x, P)
        if reason:
            return None, None, reason
        return x[0, [0, 2]], P[0][np.ix_([0, 2], [0, 2])], None

    def _push(self, source: str, track_id: str, report: TrackReport, stream: str) -> None:
        route = self.shard.route(track_id, float(report.mu[0]), float(report.mu[1]))   # another shard's track?
        if route == 'skip':
            return
        for instant in self.core.push(source, track_id, report if route == 'hold' else None, t=report.t, stream=stream):
            self._publish(instant)

    # -- scoring -------------------------------------------------------------------------
    def tick(self) -> None:
        instant = self.core.score(self._now())
        if instant is not None:
            self._publish(instant)

    def _publish(self, instant: Instant) -> None:
        if instant.error is not None:  # inputs were validated; a failure here is a bug worth one line
            self.get_logger().error(instant.error)
            return
        for a, b, reason in instant.skipped:  # isolated by the core; the other pairs were scored
            self.refuse(FUSION_SCORES, f'pair {a} | {b}: {reason}')
        p, t, ids, mu = self.p, instant.t, instant.ids, instant.mu
        q = instant.pairs if p.publish_pairs == 'nonzero' else instant.all_pairs()
        keep = self.region.owns(mu[q.ia], mu[q.ib])       # a shard publishes the pairs it owns
        if p.publish_pairs == 'nonzero':
            keep &= (q.score > 0) | (q.combined > 0) | q.associated
        q = q.subset(keep)
        pairs = FusionPairs(t, [ids[k] for k in q.ia.tolist()], [ids[k] for k in q.ib.tolist()], q.score, q.combined,
                            q.instants, q.associated, p.method, p.combine, p.window, float(self.core.threshold))
        self.pub_scores.publish(pairs.to_msg())
        self.pub_assoc.publish(pairs.select(pairs.associated).to_msg())
        scored = instant.pairs.subset(instant.pairs.associated)       # the order of instant.fused
        f = [x for x, own in zip(instant.fused, self.region.owns(mu[scored.ia], mu[scored.ib]), strict=True) if own]
        self.pub_fused.publish(FusedTracks(t, [x.a for x in f], [x.b for x in f], np.array([x.mu for x in f]),
                                           np.array([x.P for x in f])).to_msg())
        if self._displayed is None or t - self._displayed >= 1.0 / p.display_rate - 1e-9 or t < self._displayed:
            self._displayed = t
            self.pub_markers.publish(self.markers.build(instant, q))
