"""``report_source``: a simulated surveillance source reporting ships with 2σ error ellipses.

The truth is a batch of constant-velocity ships (``targets``: flat [x, vx, y, vy, ...],
``truth_seed``, ``q_s``). Two sources given the same truth parameters see the same ships, each
with its own error ellipse (1σ semi-axes ``sigma_major``/``sigma_minor``, major axis at
``bearing_deg`` clockwise from north; eqs. 56–59 of the geofeasibility paper), rate
(``period``), dropouts (``dropout``) and noise (``noise_seed``). It reports the ships listed in
``report_targets`` (−1: all) as PoseWithCovarianceStamped on ``<prefix>/t<i>``, one track per
topic under its own local id; with ``publish_truth`` it also publishes every ship's true state
on ``<prefix>/truth`` (Odometry, child_frame_id ``t<i>``) for evaluation.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from geometry_msgs.msg import PoseWithCovarianceStamped
from nav_msgs.msg import Odometry

from track_core.demo import CVTarget
from track_core.geofeasibility.ellipse import ellipse_to_gaussian
from track_msgs_py.odometry import cv_state_to_odometry, position_to_pose_cov
from track_msgs_py.qos import ESTIMATE_QOS
from track_msgs_py.topics import FRAME_MAP
from track_nodes.base import FixedRateSteps, ParameterError, TrackNode, param


@dataclass
class ReportSourceParams:
    """Parameters of ``report_source``."""

    targets: list[float] = param([0.0, 5.0, 0.0, 0.0], 'initial ship states, flat [x, vx, y, vy, ...] [m, m/s]')
    truth_seed: int = param(0, 'seed of the ships\' process noise (same value = same ships)', 0, 2**31 - 1)
    q_s: float = param(0.01, 'process-noise intensity of the ships [m²/s³]', 0.0, 100.0)
    period: float = param(1.0, 'report interval [s]', 1e-3, 3600.0, live=True)
    report_targets: list[int] = param([-1], 'indices of the ships this source reports; [-1] = all')
    sigma_major: float = param(20.0, '1σ error along the major axis of the report ellipse [m]', 1e-3, 1e6)
    sigma_minor: float = param(10.0, '1σ error along the minor axis [m]', 1e-3, 1e6)
    bearing_deg: float = param(0.0, 'bearing of the major axis, clockwise from north [deg]', -360.0, 360.0)
    dropout: float = param(0.0, 'probability that a report is missing', 0.0, 0.99, live=True)
    noise_seed: int = param(1, 'seed of this source\'s report noise and dropouts', 0, 2**31 - 1)
    prefix: str = param('/source', 'topic prefix: reports on <prefix>/t<i>, truth on <prefix>/truth')
    publish_truth: bool = param(False, 'also publish the true ship states (evaluation only)')


class ReportSourceNode(TrackNode):
    DEFAULT_NAME = 'report_source'
    Params = ReportSourceParams
    p: ReportSourceParams  # the declared parameters (base/params.py)

    def setup(self) -> None:
        p = self.p
        x0 = np.asarray(p.targets, dtype=float)
        if x0.size == 0 or x0.size % 4 or not np.all(np.isfinite(x0)):
            raise ParameterError(f'parameter targets has {x0.size} values: allowed a multiple of 4 finite numbers')
        if p.sigma_minor > p.sigma_major:
            raise ParameterError(f'parameter sigma_minor={p.sigma_minor} exceeds sigma_major={p.sigma_major}')
        n = x0.size // 4
        idx = list(range(n)) if list(p.report_targets) == [-1] else list(p.report_targets)
        if any(not 0 <= i < n for i in idx):
            raise ParameterError(f'parameter report_targets={list(p.report_targets)} is invalid: '
                             f'allowed indices 0..{n - 1}')
        self.idx = idx
        self.truth_rng = np.random.default_rng(p.truth_seed)
        self.noise_rng = np.random.default_rng(p.noise_seed)
        _, self.R = ellipse_to_gaussian(0.0, 0.0, 2 * p.sigma_major, 2 * p.sigma_minor, np.radians(p.bearing_deg))
        self.ships = CVTarget(x0.reshape(n, 4), T=p.period, q_s=p.q_s, R=self.R)
        prefix = p.prefix.rstrip('/')
        self.pubs = {i: self.create_publisher(PoseWithCovarianceStamped, f'{prefix}/t{i}', ESTIMATE_QOS) for i in idx}
        self.pub_truth = self.create_publisher(Odometry, f'{prefix}/truth', ESTIMATE_QOS) if p.publish_truth else None
        self.steps = FixedRateSteps(self, p.period, self._step)

    def apply_params(self, changed: set[str]) -> None:
        if 'period' in changed:  # dropout is read at each step
            self.steps.set_period(self.p.period)
            self.ships.set_period(self.p.period)

    def _step(self, t: float) -> None:
        x = self.ships.step(self.truth_rng)  # same truth_seed → same ships in every source
        z = self.ships.report(self.noise_rng)
        keep = self.noise_rng.random(len(x)) >= self.p.dropout
        for i in self.idx:
            if keep[i]:
                self.pubs[i].publish(position_to_pose_cov(t, z[i], self.R, FRAME_MAP))
        if self.pub_truth is not None:
            for i in range(len(x)):
                self.pub_truth.publish(cv_state_to_odometry(t, x[i], np.zeros((4, 4)), FRAME_MAP, f't{i}'))
