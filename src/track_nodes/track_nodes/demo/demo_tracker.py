"""``demo_tracker``: Kalman tracker of the demo target from its noisy position reports.

Subscribes ``/demo/reports`` (PoseWithCovarianceStamped), validates each message (finite,
symmetric PSD covariance, known frame, non-decreasing stamp) and fuses the valid ones with
``track_core.demo.CVKalmanTracker``; publishes the track on ``/demo/track`` (Odometry,
``child_frame_id`` = ``track_id``). The input policy (``track_msgs_py.validate.InputPolicy``,
horizon ``stamp_horizon``) also refuses positions beyond the world bound, covariances with a
variance below the floor or above the ceiling, zero stamps and stamps more than the horizon ahead
of the node's clock (``clock_now``: not while the clock still reads zero). A bad message goes to
``refuse`` (counted, throttled log, /diagnostics) and changes nothing, not even the stamp watermark.

Look-ahead: a report stamped more than ``stamp_lead`` s (a few report periods) ahead of the node
clock is refused (``InputPolicy.lead``), so one source with a fast clock cannot push the watermark
ahead and blank the track for every honest report after it.

Innovation gate (``track_core.filters.gating.InnovationGate``): once the track is initialised, a
report whose Mahalanobis distance² from the prediction exceeds the χ² quantile of
``gate_probability`` (2 degrees of freedom) is refused (``innovation gate`` on /diagnostics); when
at least half of the last reports were refused, a warning says the topic carries a second source
(throttled). A lost track is not locked out: after ``gate_max_misses`` consecutive refusals with no
report accepted for ``gate_lost_time`` s, or a gap of more than ``gate_max_gap`` s, the tracker starts
again from the report, with one line and a count (``reinitialisations``). A fast second publisher
cannot take the track over while the honest one keeps coming: its misses are many, but never that late.

A jump of the clock (``track_nodes.base.timejump``: back, or forward beyond the horizon; a bag
replayed in a loop, a simulator reset) resets the tracker, the gate and the stamp watermark.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from geometry_msgs.msg import PoseWithCovarianceStamped
from nav_msgs.msg import Odometry

from track_core.demo import CVKalmanTracker
from track_core.filters.gating import InnovationGate
from track_msgs_py.odometry import cv_state_to_odometry, pose_cov_to_position
from track_msgs_py.qos import ESTIMATE_QOS, SENSOR_SUB_QOS
from track_msgs_py.topics import DEMO_REPORTS, DEMO_TRACK, KNOWN_FRAMES
from track_msgs_py.validate import (
    InputPolicy,
    StampMonotonic,
    clock_now,
    pose_cov_bounds_problem,
    pose_cov_problem,
    stamp_problem,
)
from track_nodes.base import TrackNode, param


@dataclass
class DemoTrackerParams:
    """Parameters of ``demo_tracker``."""

    q_s: float = param(0.05, 'process-noise intensity of the CV model [m²/s³]', 0.0, 100.0)
    sigma_v0: float = param(5.0, 'prior standard deviation of each velocity axis at initialisation [m/s]', 1e-3, 1e3)
    track_id: str = param('demo_track', 'child_frame_id of the published track')
    stamp_horizon: float = param(InputPolicy.horizon, 'refuse reports stamped more than this ahead of the node clock '
                                 '[s]', 1e-3, 1e9, live=True)
    stamp_lead: float = param(1.0, 'look-ahead tolerance: refuse reports stamped more than this ahead of the node '
                              'clock (a few report periods) [s]', 1e-3, 1e9, live=True)
    gate_probability: float = param(0.9999, 'innovation gate: χ² probability of the Mahalanobis gate (2 dof)',
                                    0.5, 1.0 - 1e-12, live=True)
    gate_max_misses: int = param(10, 'consecutive gate refusals after which the track is re-initialised', 1, 1_000_000)
    gate_lost_time: float = param(2.0, 'a track is lost only after gate_max_misses refusals with no report accepted '
                                  'for this long [s]', 0.0, 1e9)
    gate_max_gap: float = param(30.0, 'a report after a longer gap is not gated: the track starts again [s]', 1e-3, 1e9)


class DemoTrackerNode(TrackNode):
    DEFAULT_NAME = 'demo_tracker'
    Params = DemoTrackerParams
    p: DemoTrackerParams  # the declared parameters (base/params.py)

    def setup(self) -> None:
        self.tracker = CVKalmanTracker(q_s=self.p.q_s, sigma_v0=self.p.sigma_v0)
        self.stamps = StampMonotonic()
        self.policy = InputPolicy(horizon=self.p.stamp_horizon, lead=self.p.stamp_lead)
        self.gate = InnovationGate(self.p.gate_probability, 2, self.p.gate_max_misses, self.p.gate_max_gap,
                                   lost_time=self.p.gate_lost_time)
        self.reinitialisations = 0
        self.rejected = 0
        self.pub = self.create_publisher(Odometry, DEMO_TRACK, ESTIMATE_QOS)
        self.sub = self.create_subscription(PoseWithCovarianceStamped, DEMO_REPORTS, self._on_report, SENSOR_SUB_QOS)

    def _reject(self, reason: str) -> None:
        self.rejected += 1
        self.refuse(DEMO_REPORTS, reason)

    def apply_params(self, changed: set[str]) -> None:
        self.policy = InputPolicy(horizon=self.p.stamp_horizon, lead=self.p.stamp_lead)
        self.gate.set_probability(self.p.gate_probability)

    def reset_time_state(self) -> tuple[str, ...]:
        self.tracker.reset()
        self.gate.reset()
        self.stamps.reset()
        return ('tracker', 'innovation gate', 'stamp watermark')

    def _on_report(self, msg: PoseWithCovarianceStamped) -> None:
        t, z, R = pose_cov_to_position(msg)
        last = self.stamps.last(DEMO_REPORTS)
        reason = (pose_cov_problem(msg, KNOWN_FRAMES) or pose_cov_bounds_problem(msg, self.policy)
                  or stamp_problem(t, clock_now(self.get_clock().now().nanoseconds), self.policy)
                  or self.stamps.problem(DEMO_REPORTS, t))
        if reason:
            self._reject(reason)
            return
        try:
            decision, x, P = self.tracker.update_gated(t, z, R, self.gate)
        except ValueError as exc:  # the core refused it
            decision, x, P, reason = None, None, None, f'tracker: {exc}'
        if decision is None or not decision.accepted:  # the watermark goes back to the last accepted stamp
            self.stamps.reset(DEMO_REPORTS)
            if last is not None:
                self.stamps.problem(DEMO_REPORTS, last)
            self._reject(reason if decision is None else decision.reason())
            if decision is not None and self.gate.persistent:
                self.get_logger().warning(
                    f'{self.resolved(DEMO_REPORTS)}: the innovation gate refuses {self.gate.rejected_share:.0%} of '
                    'the recent reports: a second publisher on the topic, or a wrong report covariance?',
                    throttle_duration_sec=self.WARN_THROTTLE)
            return
        if decision.reinitialise:
            self.reinitialisations += 1
            self.get_logger().warning(
                f'{self.resolved(DEMO_REPORTS)}: track re-initialised on a report {math.sqrt(decision.d2):.3g} σ '
                f'from it ({self.reinitialisations} so far): the target was lost or jumped',
                throttle_duration_sec=self.WARN_THROTTLE)
        self.pub.publish(cv_state_to_odometry(t, x, P, msg.header.frame_id, self.p.track_id))
