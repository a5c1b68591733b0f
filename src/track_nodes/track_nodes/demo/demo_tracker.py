"""``demo_tracker``: Kalman tracker of the demo target from its noisy position reports.

Subscribes ``/demo/reports`` (PoseWithCovarianceStamped), validates each message (finite,
symmetric PSD covariance, known frame, non-decreasing stamp) and fuses the valid ones with
``track_core.demo.CVKalmanTracker``; publishes the track on ``/demo/track`` (Odometry,
``child_frame_id`` = ``track_id``). The input policy (``track_msgs_py.validate.InputPolicy``,
horizon ``stamp_horizon``) also refuses positions beyond the world bound, covariances with a
variance below the floor or above the ceiling, zero stamps and stamps more than the horizon ahead
of the node's clock (``clock_now``: not while the clock still reads zero). A bad message goes to
``refuse`` (counted, throttled log, /diagnostics) and changes nothing, not even the stamp watermark.
"""

from __future__ import annotations

from geometry_msgs.msg import PoseWithCovarianceStamped
from nav_msgs.msg import Odometry

from track_core.demo import CVKalmanTracker
from track_msgs_py.convert import cv_state_to_odometry, pose_cov_to_position
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
from track_nodes.base import Param, TrackNode

PARAMS = (
    Param('q_s', 0.05, 'process-noise intensity of the CV model [m²/s³]', 0.0, 100.0),
    Param('sigma_v0', 5.0, 'prior standard deviation of each velocity axis at initialisation [m/s]', 1e-3, 1e3),
    Param('track_id', 'demo_track', 'child_frame_id of the published track'),
    Param('stamp_horizon', InputPolicy.horizon, 'refuse reports stamped more than this ahead of the node clock [s]',
          1e-3, 1e9, live=True),
)


class DemoTrackerNode(TrackNode):
    DEFAULT_NAME = 'demo_tracker'
    PARAMS = PARAMS

    def setup(self) -> None:
        self.tracker = CVKalmanTracker(q_s=self.p.q_s, sigma_v0=self.p.sigma_v0)
        self.stamps = StampMonotonic()
        self.policy = InputPolicy(horizon=self.p.stamp_horizon)
        self.rejected = 0
        self.pub = self.create_publisher(Odometry, DEMO_TRACK, ESTIMATE_QOS)
        self.sub = self.create_subscription(PoseWithCovarianceStamped, DEMO_REPORTS, self._on_report, SENSOR_SUB_QOS)

    def _reject(self, reason: str) -> None:
        self.rejected += 1
        self.refuse(DEMO_REPORTS, reason)

    def apply_params(self, changed: set[str]) -> None:
        self.policy = InputPolicy(horizon=self.p.stamp_horizon)

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
            x, P = self.tracker.update(t, z, R)
        except ValueError as exc:  # the core refused it: the watermark goes back to the last accepted stamp
            self.stamps.reset(DEMO_REPORTS)
            if last is not None:
                self.stamps.problem(DEMO_REPORTS, last)
            self._reject(f'tracker: {exc}')
            return
        self.pub.publish(cv_state_to_odometry(t, x, P, msg.header.frame_id, self.p.track_id))
