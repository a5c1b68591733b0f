"""``fusion``: geofeasibility scoring and track-to-track association of every pair of tracks.

Subscribes to the track topics listed in ``odometry_topics`` (nav_msgs/Odometry; the track id
is ``<topic>/<child_frame_id>``, so one topic may carry several tracks of one source) and
``pose_topics`` (PoseWithCovarianceStamped; one track per topic, and the topic's namespace is
its source: ``/radar/t0`` and ``/radar/t1`` are two tracks of ``/radar``) and
``pose_track_topics`` (PoseWithCovarianceStamped carrying many tracks of one source, the source
being the topic: the local track id travels in ``header.frame_id`` as ``"<frame>#<local id>"``,
``track_msgs_py.topics.track_frame_id``, and the track id is ``<topic>/<local id>``; these
subscriptions keep ``TRACKS_QOS_DEPTH`` messages, so a source may publish all its ships at one
instant). Pairs within one source are not scored unless ``same_source_pairs`` (a source does
not report a ship twice).
Every incoming message is validated (finite, symmetric PSD covariance, known frame,
non-decreasing stamp per track) and held to the input policy (``track_msgs_py.validate.
InputPolicy``: positions and velocities within the bounds, x/y variances within the floor and
ceiling, no zero stamp, none more than ``stamp_horizon`` ahead of the node clock once it runs, nor more
than ``stamp_lead``, the look-ahead tolerance, so one fast clock cannot blank its track);
a bad one is refused (``refuse``: counted per reason, one log line per reason every
``warn_period`` seconds, /diagnostics) without touching any state or watermark. A pair whose
score still fails is skipped and reported (``Instant.skipped``); every other pair is scored.

Only the x/y blocks of the covariances are read (``track_msgs_py.covariance``: z/roll/pitch are 0 by
the planar convention, yaw is not estimated). Velocities with ``not_estimated`` variance (≥
``NOT_ESTIMATED_VARIANCE``, e.g. the IDSQ network's estimate) are ignored: such a track is held like
a position report instead of being predicted with a 1e6 m²/s² velocity variance.

Schedule. ``schedule:=timer`` (default): score at every tick of a ``rate`` Hz timer on the node
clock, with the reports received so far. ``schedule:=stamps``: score at the instants
t_k = k/``rate`` of the *data* (the first one at or after the first report's stamp), and score
t_k only once a report stamped ≥ t_k + 1/``rate`` has arrived, using the reports stamped ≤ t_k.
The output then depends only on the reports' stamps and contents, not on when they arrive, as
long as every report stamped ≤ t_k arrives before any report stamped ≥ t_k + 1/``rate`` (sources
on one clock, lagging each other by less than one period): a recorded bag replayed into a fresh
node reproduces every score. The last instant of a run is scored only when a later report comes.
The rule lives in ``track_core.fusion.StampSchedule``, run by the associator.

At ``rate`` Hz it brings every live track to the current node time (``TrackTable``: Odometry
tracks are predicted with their velocity, position reports are held until ``stale_after``),
scores every pair from different sources with ``method`` (paper eqs. 49–71, batched over pairs;
``mc`` shares one draw among the pairs of an instant; ``exact`` scores only the pairs whose 2σ
ellipses may overlap, the others score 0 as scoring gives: ``track_core.geofeasibility.gate``),
keeps the last ``window`` instant
scores per pair and combines them (harmonic or geometric mean, §1; one zero instant makes the
combination zero, as the paper's means do), and publishes:

| topic | type | content |
|---|---|---|
| /fusion/scores | DiagnosticArray | one status per pair ``A | B``: score, combined, instants, associated, method |
| /fusion/associations | DiagnosticArray | the pairs whose combined score ≥ ``threshold`` |
| /fusion/fused | Odometry | covariance intersection of each associated pair, child_frame_id ``A+B`` (no leading '/') |
| /fusion/markers | MarkerArray | 2σ ellipse per track, a link per pair coloured red→green by score |

``publish_pairs:=nonzero`` publishes (scores, links) only the pairs with a positive instant or combined
score or associated; every pair left out scored 0 and has a combined score of 0. With the exact
score most pairs of a large picture are never scored (the core's gate), and one status per pair of
1000 tracks (250,000 a tick) is more than a node can publish at 1 Hz; ``all`` (default) keeps one
status per scored pair.

The pairing, masking, windows, thresholds and covariance intersection are
``track_core.fusion.PairAssociator``; a pair's status is ``track_msgs_py.records.fusion.FusionPairScore``;
the markers are built by ``track_msgs_py.markers.fusion``. This node validates and converts the
messages, runs the timer, and publishes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseWithCovarianceStamped
from nav_msgs.msg import Odometry
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from visualization_msgs.msg import MarkerArray

from track_core.fusion import Instant, PairAssociator, TrackReport
from track_core.geofeasibility.track import THRESHOLD
from track_msgs_py.covariance import not_estimated
from track_msgs_py.diagnostics import diagnostic_array
from track_msgs_py.markers.fusion import FusionMarkers
from track_msgs_py.odometry import cv_state_to_odometry, odometry_to_cv_state, pose_cov_to_position
from track_msgs_py.qos import ESTIMATE_QOS
from track_msgs_py.records.fusion import FusionPairScore
from track_msgs_py.stamps import stamp_to_sec
from track_msgs_py.topics import (
    FRAME_MAP,
    FUSION_ASSOCIATIONS,
    FUSION_FUSED,
    FUSION_MARKERS,
    FUSION_SCORES,
    KNOWN_FRAMES,
    fused_track_id,
    split_track_frame_id,
)
from track_msgs_py.validate import (
    InputPolicy,
    StampMonotonic,
    clock_now,
    frame_problem,
    odometry_bounds_problem,
    odometry_problem,
    pose_cov_bounds_problem,
    pose_cov_problem,
    stamp_problem,
)
from track_nodes.base import ParameterError, TrackNode, param

# Best effort accepts both reliable and best-effort publishers; depth covers a few rate periods.
TRACK_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=50, reliability=ReliabilityPolicy.BEST_EFFORT)
# Topics carrying many tracks (pose_track_topics): one burst per instant holds every ship of a source.
TRACKS_QOS_DEPTH = 1000
TRACKS_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=TRACKS_QOS_DEPTH,
                        reliability=ReliabilityPolicy.BEST_EFFORT)


@dataclass
class FusionParams:
    """Parameters of ``fusion``."""

    odometry_topics: list[str] = param([''], 'nav_msgs/Odometry track topics (track id = topic/child_frame_id)')
    pose_topics: list[str] = param([''], 'PoseWithCovarianceStamped track topics (one track per topic)')
    pose_track_topics: list[str] = param([''], 'PoseWithCovarianceStamped topics of many tracks of one source '
        '(header.frame_id = "<frame>#<local id>", track id = topic/<local id>)')
    rate: float = param(2.0, 'scoring rate [Hz]', 0.01, 100.0, live=True)
    method: str = param('exact', 'geofeasibility score', choices=('exact', 'glr', 'glr_thresholded', 'mc'))
    n_samples: int = param(500, 'Monte-Carlo samples per pair (method mc)', 10, 1_000_000)
    threshold: float = param(THRESHOLD, 'associate a pair when its combined score is at least this',
                             0.0, 1.0, live=True)
    combine: str = param('geometric', 'track-level combination of instant scores', choices=('geometric', 'harmonic'))
    window: int = param(10, 'instant scores kept per pair for the combination', 1, 100_000)
    stale_after: float = param(2.0, 'a position report older than this drops out [s]', 1e-3, 1e6, live=True)
    max_prediction: float = param(10.0, 'an Odometry track predicted further than this drops out [s]',
                                  1e-3, 1e6, live=True)
    q_s: float = param(0.1, 'CV process-noise intensity used when predicting tracks [m²/s³]', 0.0, 1e6)
    seed: int = param(0, 'seed of the Generator used by the mc method', 0, 2**31 - 1)
    same_source_pairs: bool = param(False, 'also score pairs from one source (Odometry: same topic; pose: same '
        'namespace)')
    schedule: str = param('timer', 'timer: score at node-clock ticks; stamps: at the data instants k/rate, '
        'deterministic (module docstring)', choices=('timer', 'stamps'))
    publish_pairs: str = param('all', 'all: a status and a link per scored pair; nonzero: only the pairs with a '
        'positive score or combined score, or associated (module docstring)', choices=('all', 'nonzero'))
    warn_period: float = param(5.0, 'at most one bad-input warning per topic per this many seconds',
                               0.0, 1e6, live=True)
    stamp_horizon: float = param(InputPolicy.horizon, 'refuse reports stamped more than this ahead of the node clock '
                                 '[s]', 1e-3, 1e9, live=True)
    stamp_lead: float = param(2.0, 'look-ahead tolerance: refuse reports stamped more than this ahead of the node '
        'clock (a few report periods) [s]', 1e-3, 1e9, live=True)



class FusionNode(TrackNode):
    DEFAULT_NAME = 'fusion'
    Params = FusionParams
    p: FusionParams  # the declared parameters (base/params.py)

    def setup(self) -> None:
        p = self.p
        odo = [t for t in p.odometry_topics if t]
        pose = [t for t in p.pose_topics if t]
        multi = [t for t in p.pose_track_topics if t]
        if not odo and not pose and not multi:
            raise ParameterError('parameters odometry_topics, pose_topics and pose_track_topics are all empty: '
                             'nothing to fuse')
        self.core = PairAssociator(p.method, p.threshold, p.combine, p.window, n_samples=p.n_samples,
                                   same_source_pairs=p.same_source_pairs, stale_after=p.stale_after,
                                   max_prediction=p.max_prediction, q_s=p.q_s, seed=p.seed,
                                   stamp_rate=p.rate if p.schedule == 'stamps' else None)
        self.markers = FusionMarkers(lifetime=2.0 / p.rate)
        self.stamps = StampMonotonic()
        self.policy = InputPolicy(horizon=p.stamp_horizon, lead=p.stamp_lead)
        self.refusals.throttle = p.warn_period
        self.dropped: dict[str, int] = {}
        # The track topics are the user's names, as given: relative ones resolve in the node's namespace.
        # Track ids use the resolved name (track_id = <resolved topic>/<id>), the same in any namespace form.
        self.subs = [self._track_sub(Odometry, t, '_on_odometry', TRACK_QOS) for t in odo]
        self.subs += [self._track_sub(PoseWithCovarianceStamped, t, '_on_pose', TRACK_QOS) for t in pose]
        self.subs += [self._track_sub(PoseWithCovarianceStamped, t, '_on_pose_track', TRACKS_QOS) for t in multi]
        self.pub_scores = self.create_publisher(DiagnosticArray, FUSION_SCORES, ESTIMATE_QOS)
        self.pub_assoc = self.create_publisher(DiagnosticArray, FUSION_ASSOCIATIONS, ESTIMATE_QOS)
        self.pub_fused = self.create_publisher(Odometry, FUSION_FUSED, ESTIMATE_QOS)
        self.pub_markers = self.create_publisher(MarkerArray, FUSION_MARKERS, ESTIMATE_QOS)
        self.timer = self.create_timer(1.0 / p.rate, self.tick) if p.schedule == 'timer' else None

    def _track_sub(self, cls, topic: str, handler: str, qos):
        """A track topic's subscription; the handler is looked up at call time (tests wrap it)."""
        name = self.resolve_topic_name(topic)
        return self.create_subscription(cls, topic, lambda m: getattr(self, handler)(name, m), qos, as_given=True)

    def validate_params(self, p) -> None:
        if p.schedule == 'stamps' and p.rate != self.p.rate:
            raise ParameterError('parameter rate is fixed with schedule=stamps (it sets the scoring instants k/rate)')

    def apply_params(self, changed: set[str]) -> None:
        p, core = self.p, self.core
        core.threshold = float(p.threshold)
        core.table.stale_after, core.table.max_prediction = float(p.stale_after), float(p.max_prediction)
        self.refusals.throttle = float(p.warn_period)
        self.policy = InputPolicy(horizon=p.stamp_horizon, lead=p.stamp_lead)
        if 'rate' in changed and self.timer is not None:
            self.timer.timer_period_ns = round(1e9 / p.rate)
            self.markers.lifetime = 2.0 / p.rate

    def reset_time_state(self) -> tuple[str, ...]:
        self.core.reset()
        self.stamps.reset()
        return ('tracks', 'pair windows', 'stamp schedule', 'stamp watermarks')

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

    def _on_odometry(self, topic: str, msg: Odometry) -> None:
        track_id = f'{topic}/{msg.child_frame_id}' if msg.child_frame_id else topic
        reason = (odometry_problem(msg, KNOWN_FRAMES) or odometry_bounds_problem(msg, self.policy)
                  or self._stamp_problem(msg) or self.stamps.msg_problem(track_id, msg))
        if reason:
            self._drop(topic, reason)
            return
        t, x, P = odometry_to_cv_state(msg)
        Pv = P[np.ix_([1, 3], [1, 3])]
        if np.any(not_estimated(np.diag(Pv))):  # velocity not estimated: hold the position
            self._push(topic, track_id, TrackReport(t, x[[0, 2]], P[np.ix_([0, 2], [0, 2])]))
            return
        self._push(topic, track_id, TrackReport(t, x[[0, 2]], P[np.ix_([0, 2], [0, 2])], x[[1, 3]], Pv))

    def _on_pose(self, topic: str, msg: PoseWithCovarianceStamped) -> None:
        reason = (pose_cov_problem(msg, KNOWN_FRAMES) or pose_cov_bounds_problem(msg, self.policy)
                  or self._stamp_problem(msg) or self.stamps.msg_problem(topic, msg))
        if reason:
            self._drop(topic, reason)
            return
        t, z, R = pose_cov_to_position(msg)
        # One track per topic; a source publishes its tracks under one namespace (<source>/<track>).
        self._push(topic.rsplit('/', 1)[0] or topic, topic, TrackReport(t, z, R))

    def _on_pose_track(self, topic: str, msg: PoseWithCovarianceStamped) -> None:
        frame, local = split_track_frame_id(msg.header.frame_id)
        if not local:
            self._drop(topic, f'header.frame_id: {msg.header.frame_id!r} carries no track id '
                              '(expected "<frame>#<local id>")')
            return
        track_id = f'{topic}/{local}'
        reason = (frame_problem(frame, KNOWN_FRAMES) or pose_cov_problem(msg, None)
                  or pose_cov_bounds_problem(msg, self.policy) or self._stamp_problem(msg)
                  or self.stamps.msg_problem(track_id, msg))
        if reason:
            self._drop(topic, reason)
            return
        t, z, R = pose_cov_to_position(msg)
        self._push(topic, track_id, TrackReport(t, z, R))  # the topic is the source

    def _push(self, source: str, track_id: str, report: TrackReport) -> None:
        for instant in self.core.push(source, track_id, report):
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
        t = instant.t
        for f in instant.fused:
            P4 = np.zeros((4, 4))
            P4[0::2, 0::2] = f.P  # the x/y rows and columns of the CV state [x, ẋ, y, ẏ]
            self.pub_fused.publish(cv_state_to_odometry(t, np.array([f.mu[0], 0.0, f.mu[1], 0.0]), P4, FRAME_MAP,
                                                        fused_track_id(f.a, f.b)))
        pairs = instant.pairs.nonzero() if self.p.publish_pairs == 'nonzero' else instant.all_pairs()
        statuses = [FusionPairScore(q.score, q.combined, q.instants, q.associated, self.p.method).pair_status(q.a, q.b)
                    for q in pairs]
        self.pub_scores.publish(diagnostic_array(t, statuses))
        self.pub_assoc.publish(diagnostic_array(t, [st for st, q in zip(statuses, pairs, strict=True)
                                                    if q.associated]))
        self.pub_markers.publish(self.markers.build(instant, pairs))
