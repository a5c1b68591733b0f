"""``demo_target``: truth simulator of a constant-velocity target with noisy position reports.

Publishes the true state (``/demo/truth``, nav_msgs/Odometry) and a position report with its
covariance (``/demo/reports``, PoseWithCovarianceStamped) every ``T`` seconds of node time.

Determinism: ``node_util.FixedRateSteps`` stamps step k at ``origin + k·T`` and catches up a
late timer step by step, so a seed and a ``/clock`` reproduce every payload.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from geometry_msgs.msg import PoseWithCovarianceStamped
from nav_msgs.msg import Odometry

from track_core.demo import CVTarget
from track_msgs_py.odometry import cv_state_to_odometry, position_to_pose_cov
from track_msgs_py.qos import ESTIMATE_QOS, SENSOR_QOS
from track_msgs_py.topics import DEMO_REPORTS, DEMO_TRUTH, FRAME_MAP
from track_nodes.base import FixedRateSteps, TrackNode, param, vector


@dataclass
class DemoTargetParams:
    """Parameters of ``demo_target``."""

    seed: int = param(0, 'seed of the numpy Generator driving truth and report noise', 0, 2**31 - 1)
    period: float = param(0.1, 'sample interval T of truth and reports [s]', 1e-3, 60.0, live=True)
    q_s: float = param(0.05, 'process-noise intensity of the CV truth [m²/s³]', 0.0, 100.0)
    sigma_r: float = param(2.0, 'standard deviation of each position-report axis [m]', 1e-3, 1e4)
    x0: list[float] = param([0.0, 5.0, 0.0, 2.0], 'initial state [x, vx, y, vy] in map [m, m/s]')
    max_time: float = param(0.0, 'stop publishing after this node time since origin [s]; 0 = never', 0.0, 1e9)
    track_id: str = param('demo_target', 'child_frame_id of the truth odometry')


class DemoTargetNode(TrackNode):
    DEFAULT_NAME = 'demo_target'
    Params = DemoTargetParams
    p: DemoTargetParams  # the declared parameters (base/params.py)

    def setup(self) -> None:
        p = self.p
        x0 = vector('x0', p.x0, 4)
        self.p = p
        self.rng = np.random.default_rng(p.seed)
        self.target = CVTarget(x0, T=p.period, q_s=p.q_s, R=np.eye(2) * p.sigma_r**2)
        self.pub_truth = self.create_publisher(Odometry, DEMO_TRUTH, ESTIMATE_QOS)
        self.pub_report = self.create_publisher(PoseWithCovarianceStamped, DEMO_REPORTS, SENSOR_QOS)
        self.steps = FixedRateSteps(self, p.period, self._step, p.max_time)

    def apply_params(self, changed: set[str]) -> None:
        if 'period' in changed:  # the next step comes one new period after the last one
            self.steps.set_period(self.p.period)
            self.target.set_period(self.p.period)

    def _step(self, t: float) -> None:
        x = self.target.step(self.rng)
        z = self.target.report(self.rng)
        self.pub_truth.publish(cv_state_to_odometry(t, x, np.zeros((4, 4)), FRAME_MAP, self.p.track_id))
        self.pub_report.publish(position_to_pose_cov(t, z, self.target.R, FRAME_MAP))
