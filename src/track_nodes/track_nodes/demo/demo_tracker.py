"""``demo_tracker``: Kalman tracker of the demo target from its noisy position reports.

Subscribes ``/demo/reports`` (PoseWithCovarianceStamped), validates each message (finite,
symmetric PSD covariance, known frame, non-decreasing stamp) and fuses the valid ones with
``track_core.demo.CVKalmanTracker``; publishes the track on ``/demo/track`` (Odometry,
``child_frame_id`` = ``track_id``). A bad message is logged with its reason and dropped; the
node keeps running.
"""

from __future__ import annotations

from geometry_msgs.msg import PoseWithCovarianceStamped
from nav_msgs.msg import Odometry

from track_core.demo import CVKalmanTracker
from track_msgs_py.convert import cv_state_to_odometry, pose_cov_to_position
from track_msgs_py.qos import ESTIMATE_QOS, SENSOR_QOS
from track_msgs_py.topics import DEMO_REPORTS, DEMO_TRACK, KNOWN_FRAMES
from track_msgs_py.validate import StampMonotonic, pose_cov_problem
from track_nodes.base import Param, TrackNode

PARAMS = (
    Param('q_s', 0.05, 'process-noise intensity of the CV model [m²/s³]', 0.0, 100.0),
    Param('sigma_v0', 5.0, 'prior standard deviation of each velocity axis at initialisation [m/s]', 1e-3, 1e3),
    Param('track_id', 'demo_track', 'child_frame_id of the published track'),
)


class DemoTrackerNode(TrackNode):
    DEFAULT_NAME = 'demo_tracker'
    PARAMS = PARAMS

    def setup(self) -> None:
        self.tracker = CVKalmanTracker(q_s=self.p.q_s, sigma_v0=self.p.sigma_v0)
        self.stamps = StampMonotonic()
        self.rejected = 0
        self.pub = self.create_publisher(Odometry, DEMO_TRACK, ESTIMATE_QOS)
        self.sub = self.create_subscription(PoseWithCovarianceStamped, DEMO_REPORTS, self._on_report, SENSOR_QOS)

    def _reject(self, reason: str) -> None:
        self.rejected += 1
        self.get_logger().warning(f'{DEMO_REPORTS}: dropped report: {reason}')

    def _on_report(self, msg: PoseWithCovarianceStamped) -> None:
        reason = pose_cov_problem(msg, KNOWN_FRAMES)
        t, z, R = pose_cov_to_position(msg)
        reason = reason or self.stamps.problem(DEMO_REPORTS, t)
        if reason:
            self._reject(reason)
            return
        try:
            x, P = self.tracker.update(t, z, R)
        except ValueError as exc:
            self._reject(str(exc))
            return
        self.pub.publish(cv_state_to_odometry(t, x, P, msg.header.frame_id, self.p.track_id))
