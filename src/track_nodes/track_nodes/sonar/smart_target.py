"""``smart_target``: the sonar paper's target, which hears the observer's active pings and evades.

Steps ``track_core.sonar.SmartTarget`` every ``period`` T of node time (``FixedRateSteps``,
stamps t_k = origin + k·T) and publishes

- ``/sonar/target/truth`` (nav_msgs/Odometry, zero covariance, ``child_frame_id`` = ``track_id``;
  transient-local ``TRUTH_QOS``, so an observer started later still gets the step this node waits on),
- ``/sonar/target/status`` (``track_msgs/SonarTargetStatus``: ``target_id`` = ``track_id``, ``mode``
  naive|cruise|evade, ``heard``, ``pings``, ``detections``; ``track_msgs_py.records.sonar.SonarTargetStatus``).

It subscribes to the observer's active-ping events (``/sonar/ping``, geometry_msgs/PointStamped)
and to the observer's Odometry (``/sonar/observer/odom``): the range between the two sets the
detection probability of a ping (``SmartTargetParams.detection_probability``), and the observer
position sets the evasion heading. ``naive:=true`` is the paper's constant-velocity target (it
still counts the pings it hears, but never reacts).

Ordering rule (``track_core.sonar.lockstep.TargetGate``, the same as the core's closed loop,
``experiments.run_closed_loop``): step k moves x_{k-1} → x_k. It uses the ping the observer emitted
at t_{k-1} (if any) and the observer position at t_{k-1}; step 1 has no ping (the observer's first
reading is at t_1). With ``sync_observer`` (default) step k waits until the observer's Odometry
stamped t_{k-1} has arrived: the observer publishes its ping event before its Odometry, so by then
the target knows whether t_{k-1} was a ping. The observer in turn waits for the truth stamped t_k
before it measures, so the two nodes alternate T1, O1, T2, O2, … whatever the executor's callback
order, and a seed reproduces every payload. ``sync_observer:=false`` runs freely, for a target
without an observer: step k takes a ping stamped t_{k-1} only if it has already arrived, and the
latest observer position received.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from geometry_msgs.msg import PointStamped
from nav_msgs.msg import Odometry

from track_core.sonar import SmartTarget, SmartTargetParams, SonarParams
from track_core.sonar.lockstep import TargetGate
from track_msgs import msg as tm
from track_msgs_py.odometry import cv_state_to_odometry, odometry_to_cv_state
from track_msgs_py.qos import ESTIMATE_QOS, TRUTH_QOS
from track_msgs_py.records.sonar import SonarTargetStatus
from track_msgs_py.stamps import sec_to_stamp, stamp_to_ns
from track_msgs_py.topics import FRAME_MAP, KNOWN_FRAMES, SONAR_OBSERVER, SONAR_PING, SONAR_TARGET_STATUS, SONAR_TRUTH
from track_msgs_py.validate import (
    DEFAULT_POLICY,
    bound_problem,
    header_problem,
    odometry_bounds_problem,
    odometry_problem,
)
from track_nodes.base import FixedRateSteps, TrackNode, param, vector
from track_nodes.sonar.observer_params import smart_target_params

_D = SmartTargetParams()

@dataclass
class SmartTargetNodeParams:
    """Parameters of ``smart_target``."""

    seed: int = param(0, 'seed of the numpy Generator driving process noise and ping detection', 0, 2**31 - 1)
    period: float = param(1.0, 'step T of the target model (Table 1: 1 s) [s]', 1e-3, 60.0)
    q_s: float = param(1.0, 'CV process-noise intensity q_s of eq. 4 (Table 1: 1) [m²/s³]', 1e-9, 1e3)
    x0: list[float] = param([300.0, 12.25, 300.0, -12.25], 'initial state [x, vx, y, vy] in map (Section 5) [m, m/s]')
    naive: bool = param(False, 'the paper\'s constant-velocity target (never evades)')
    p_max: float = param(_D.p_max, 'detection probability of a ping at close range', 0.0, 1.0)
    r_50: float = param(_D.r_50, 'range at which a ping is heard with probability p_max/2 [m]', 1e-3, 1e7)
    width: float = param(_D.width, 'width of the logistic fall-off of the detection probability [m]', 1e-3, 1e7)
    evade_speed: float = param(_D.evade_speed, 'speed while evading [m/s]', 0.0, 1e3)
    max_turn_rate_deg: float = param(math.degrees(_D.max_turn_rate), 'bounded turn rate while manoeuvring [deg/s]',
                                     0.0, 360.0)
    max_accel: float = param(_D.max_accel, 'bounded speed change [m/s²]', 0.0, 1e3)
    quiet_period: float = param(_D.quiet_period, 'time without a detected ping before cruising again [s]', 0.0, 1e6)
    sync_observer: bool = param(True, 'step k waits for the observer\'s Odometry of t_{k-1} (deterministic lock-step)')
    max_time: float = param(0.0, 'stop after this node time since origin [s]; 0 = never', 0.0, 1e9)
    track_id: str = param('smart_target', 'child_frame_id of the truth odometry and name of the status')


class SmartTargetNode(TrackNode):
    DEFAULT_NAME = 'smart_target'
    Params = SmartTargetNodeParams
    p: SmartTargetNodeParams  # the declared parameters (base/params.py)

    def setup(self) -> None:
        p = self.p
        x0 = vector('x0', p.x0, 4)
        self.target = SmartTarget(x0, sonar=SonarParams(T=p.period, q_s=p.q_s), params=smart_target_params(p))
        self.rng = np.random.default_rng(p.seed)
        # step k waits for the observer's step k-1 (track_core.sonar.lockstep)
        self.gate = TargetGate(p.sync_observer, round(2e9 * p.period))
        self.rejected = 0
        self.pub_truth = self.create_publisher(Odometry, SONAR_TRUTH, TRUTH_QOS)  # late observers get it
        self.pub_status = self.create_publisher(tm.SonarTargetStatus, SONAR_TARGET_STATUS, ESTIMATE_QOS)
        # Ping subscription first: when both are ready at once the executor serves it first.
        self.sub_ping = self.create_subscription(PointStamped, SONAR_PING, self._on_ping, ESTIMATE_QOS)
        self.sub_obs = self.create_subscription(Odometry, SONAR_OBSERVER, self._on_observer, ESTIMATE_QOS)
        self.steps = FixedRateSteps(self, p.period, self._due, p.max_time)

    # -- inputs ---------------------------------------------------------------------------
    def _reject(self, topic: str, reason: str) -> None:
        self.rejected += 1
        self.refuse(topic, reason)

    def _on_ping(self, msg: PointStamped) -> None:
        reason = (header_problem(msg.header, KNOWN_FRAMES)
                  or bound_problem('point', DEFAULT_POLICY.world_bound, x=msg.point.x, y=msg.point.y, z=msg.point.z))
        if reason:
            self._reject(SONAR_PING, reason)
            return
        self.gate.add_ping(stamp_to_ns(msg.header.stamp), np.array([msg.point.x, msg.point.y]))

    def _on_observer(self, msg: Odometry) -> None:
        reason = odometry_problem(msg, KNOWN_FRAMES) or odometry_bounds_problem(msg, pose_covariance=False)
        if reason:
            self._reject(SONAR_OBSERVER, reason)
            return
        _, x, _ = odometry_to_cv_state(msg)
        self._take(self.gate.add_observer(stamp_to_ns(msg.header.stamp), np.array([x[0], x[2]])))

    # -- stepping -------------------------------------------------------------------------
    def _due(self, t: float) -> None:
        self._take(self.gate.due(t, _ns(t)))

    def _take(self, ready: list[tuple[float, bool, np.ndarray]]) -> None:
        for t, pinged, obs_xy in ready:
            self._step(t, pinged, obs_xy)

    def _step(self, t: float, pinged: bool, obs_xy: np.ndarray) -> None:
        tgt = self.target
        before = tgt.detections
        x = tgt.step(self.rng, pinged, obs_xy)
        self.pub_truth.publish(cv_state_to_odometry(t, x, np.zeros((4, 4)), FRAME_MAP, self.p.track_id))
        rec = SonarTargetStatus(tgt.mode, tgt.detections > before, tgt.pings, tgt.detections)
        self.pub_status.publish(rec.to_msg(t, self.p.track_id))


def _ns(t: float) -> int:
    """Float seconds → the integer nanoseconds of its stamp (stamps are compared exactly)."""
    return stamp_to_ns(sec_to_stamp(t))
