"""``sonar_observer``: the observer AUV of the sonar paper, with passive/active sonar and a particle filter.

For every target truth (``/sonar/target/truth``), in step order, the observer

1. is at ``ObserverTrajectory.state(k·T)`` (constant speed, straight legs and constant-rate turns);
2. simulates, for the truth of step k (stamped t_k), the sonar reading the scheduler chose for
   this step (``simulate_measurement``: eq. 5 passive bearing, or
   eq. 6 active bearing + range, Table 1 noise, its own seeded Generator);
3. runs one step of the tracker (``make_tracker``: ``ss-pf`` with the eq. 7 covariance-control
   scheduler, or the ``papf``/``acpf`` baselines; its own seeded Generator);
4. publishes, in this order:
   - ``/sonar/ping`` (geometry_msgs/PointStamped at the observer position), only when it pinged;
   - ``/sonar/estimate`` (nav_msgs/Odometry with the particle covariance, ``child_frame_id`` =
     ``track_id``; position–velocity cross-covariances are dropped, see track_msgs_py.odometry);
   - ``/sonar/particles`` (geometry_msgs/PoseArray, one pose per selected particle, identity
     orientation like our Odometry tracks: particles carry no heading; weights are equal after
     the selection step, so no weight field is needed; one pose, the mean, while the filter's
     mixture is merged into one Gaussian (``track_core.sonar.sspf``), when ``ess`` is 1 too);
   - ``/sonar/mode`` (diagnostic_msgs/DiagnosticArray, one status ``<node name>/sensor_mode``;
     message = the mode used at t_k; values ``mode``, ``next_mode`` (the scheduler's choice for
     t_{k+1}), ``step``, ``ess``, and for ss-pf ``distance`` = ‖P_D − Cov‖ of eq. 7: ``records.sonar.SonarMode``);
   - ``/sonar/markers`` (visualization_msgs/MarkerArray: the 2σ position ellipse, ns
     ``sonar_estimate``, id 0: ``track_msgs_py.markers.sonar``);
   - ``/sonar/observer/odom`` (nav_msgs/Odometry of the observer, zero covariance) last: it tells
     the smart target that step k is complete (see ``smart_target`` for the ordering rule), just after
     the same pose on ``/tf`` as map → ``observer_id`` (the AUV's body frame, identity orientation like
     the Odometry: the CV state carries no heading). The estimate's ``child_frame_id`` names the track,
     not a frame, and is not broadcast.

Determinism rule (``track_core.sonar.lockstep.TruthGate``): the target's truth sets the time. The
first truth accepted is step 1 and fixes the step grid (its stamp + k·T); step k is taken when the
truth of grid point k has arrived, strictly in order, and everything published for it carries that
truth's stamp exactly. The target's step k never depends on the observer's step k (only on k−1),
so there is no deadlock, and the measurement and filter draws depend only on the seed and the truth
sequence. Replaying a recorded ``/sonar/target/truth`` into a fresh observer with the same
parameters therefore reproduces every estimate bit for bit. No clock origin is shared by
convention: the two nodes start in any order, any time apart (the truth is transient-local, so an
observer started late still gets the step the target waits on). A truth off the grid, already
received, too far ahead or stamped beyond the horizon of the node's clock is refused. A jump of
the clock (``track_nodes.base.timejump``: a bag replayed in a loop, a simulator reset) starts a
new run: the tracker at its prior with its Generators seeded again, and the step grid forgotten; a
truth of the old run still queued then lies ahead of the clock by more than ``stamp_lead`` and is
refused, so it cannot fix the new grid.
The measurements are simulated here from the truth, so there is no report another publisher could
inject and no innovation gate.

Target model (``target_model``, read-only). ``cv``: the paper's constant-velocity model (eqs. 1-4).
``smart``: the SS-PF knows what its own pings do to a ``smart_target`` (``SSPF(target_model=...)``,
``track_core.sonar.sspf``): after a step it pinged, each particle draws whether its target heard the
ping with P_det(range) and, while it last heard one less than ``model_quiet_period`` ago, moves away
from the observer towards ``model_evade_speed`` with bounded turn rate and acceleration
(``smart_target.evasive_transition``). The model's parameters are this node's ``model_*`` parameters
(the observer cannot read the target's): a scenario sets them to its ``smart_target``'s values, as
``config/maritime.yaml`` does. ``prediction`` picks how each particle's Gaussian crosses the manoeuvre:
``unscented`` (its sigma points through it; where the commanded speed and heading are reached the
velocity spread contracts) or ``linear`` (its mean through it, F P Fᵀ + Q as for the CV model, so eq. 7
sees the CV model's covariance growth).

Parameters are checked at start; δ < 0, N < 1 or a P_D that is not symmetric PSD (4 values: a
diagonal; 16: a row-major 4×4 matrix) stop the node with one line.
"""

from __future__ import annotations

import math

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PointStamped, PoseArray
from nav_msgs.msg import Odometry
from visualization_msgs.msg import MarkerArray

from track_core.sonar import (
    CovarianceScheduler,
    ObserverTrajectory,
    Scenario,
    SensorMode,
    SonarParams,
    make_tracker,
    simulate_measurement,
)
from track_core.sonar.lockstep import TruthGate
from track_msgs_py.diagnostics import DIAG_OK, diagnostic_array
from track_msgs_py.markers.sonar import estimate_markers
from track_msgs_py.odometry import cv_state_to_odometry, odometry_to_cv_state, positions_to_pose_array
from track_msgs_py.qos import ESTIMATE_QOS, SENSOR_QOS, TRUTH_QOS
from track_msgs_py.records.sonar import SonarMode
from track_msgs_py.stamps import ns_to_stamp, stamp_to_ns
from track_msgs_py.tf import frame_pair_problem, odometry_transform
from track_msgs_py.topics import (
    FRAME_MAP,
    KNOWN_FRAMES,
    SONAR_ESTIMATE,
    SONAR_MARKERS,
    SONAR_MODE,
    SONAR_OBSERVER,
    SONAR_PARTICLES,
    SONAR_PING,
    SONAR_TRUTH,
)
from track_msgs_py.validate import InputPolicy, clock_now, odometry_bounds_problem, odometry_problem, stamp_problem
from track_nodes.base import ParameterError, TrackNode
from track_nodes.sonar.observer_params import SonarObserverParams, p_d, target_model_of

WAIT_WARN = 10.0  # s of the node's clock (sim time under use_sim_time) without a truth before a warning


class SonarObserverNode(TrackNode):
    DEFAULT_NAME = 'sonar_observer'
    Params = SonarObserverParams
    p: SonarObserverParams  # the declared parameters (base/params.py)

    def setup(self) -> None:
        p = self.p
        P_D = p_d(p.P_D)
        m0 = np.asarray(p.prior_mean, dtype=float)
        if m0.shape != (4,) or not np.all(np.isfinite(m0)):
            raise ParameterError(f'parameter prior_mean={list(p.prior_mean)!r} is invalid: allowed 4 finite numbers')
        legs = np.asarray(p.legs, dtype=float)
        if legs.size == 0 or legs.size % 2 or not np.all(np.isfinite(legs)) or np.any(legs[::2] <= 0):
            raise ParameterError(f'parameter legs={list(p.legs)!r} is invalid: allowed pairs [duration > 0 s, '
                             'turn rate deg/s, ...]')
        start = np.asarray(p.start, dtype=float)
        if start.shape != (2,) or not np.all(np.isfinite(start)):
            raise ParameterError(f'parameter start={list(p.start)!r} is invalid: allowed 2 finite numbers [x, y]')
        problem = frame_pair_problem(FRAME_MAP, p.observer_id)
        if problem:
            raise ParameterError(f'parameter observer_id={p.observer_id!r}: {problem}')
        self.sonar = SonarParams(T=p.period, q_s=p.q_s, sigma_b=math.radians(p.sigma_b_deg), sigma_d=p.sigma_d,
                                 n_particles=p.n_particles)
        self.trajectory = ObserverTrajectory(start=(float(start[0]), float(start[1])), speed=p.speed,
                                             heading0_deg=p.heading0_deg,
                                             legs=tuple((float(d), float(r)) for d, r in legs.reshape(-1, 2)))
        self._prior = (P_D, m0, Scenario(params=self.sonar, prior_pos_std=p.prior_pos_std,
                                         prior_vel_std=p.prior_vel_std).prior_cov)
        self._start_run()
        self.rejected = 0
        self._waiting_logged = False
        self.pub_ping = self.create_publisher(PointStamped, SONAR_PING, ESTIMATE_QOS)
        self.pub_est = self.create_publisher(Odometry, SONAR_ESTIMATE, ESTIMATE_QOS)
        self.pub_particles = self.create_publisher(PoseArray, SONAR_PARTICLES, SENSOR_QOS)
        self.pub_mode = self.create_publisher(DiagnosticArray, SONAR_MODE, ESTIMATE_QOS)
        self.pub_markers = self.create_publisher(MarkerArray, SONAR_MARKERS, ESTIMATE_QOS)
        self.pub_odom = self.create_publisher(Odometry, SONAR_OBSERVER, ESTIMATE_QOS)
        self.advertise_transforms()
        self.sub_truth = self.create_subscription(Odometry, SONAR_TRUTH, self._on_truth, TRUTH_QOS)
        # On the node's clock: a slow lock-step run (sim time) waits on its target for long wall times.
        self.last_truth: float | None = self._clock_s() or None  # None: the sim clock has not started
        self.wait_timer = self.create_timer(WAIT_WARN, self._check_waiting)

    def _start_run(self) -> None:
        """A fresh run: seeded Generators, the tracker at its prior, the truth gate at step 1."""
        p, (P_D, m0, prior_cov) = self.p, self._prior
        noise_ss, filter_ss = np.random.SeedSequence(p.seed).spawn(2)
        self.noise_rng = np.random.default_rng(noise_ss)
        self.tracker = make_tracker(p.tracker, self.sonar, np.random.default_rng(filter_ss), P_D=P_D,
                                    delta=p.delta, metric=p.metric, regularize=p.regularize,
                                    initial_pings=p.initial_pings, target_model=target_model_of(p),
                                    prediction=p.prediction)
        self.tracker.initialize(m0, prior_cov)
        self.gate = TruthGate(round(p.period * 1e9))  # step k = the truth of grid point k (track_core.sonar.lockstep)
        self.pings = 0
        self.k = 0  # steps taken

    def reset_time_state(self) -> tuple[str, ...]:
        """A new run from step 1 (as a fresh node: a replayed run reproduces its estimates again)."""
        self._start_run()
        self.last_truth = self._clock_s()  # the wait for a truth restarts on the new clock
        return ('tracker (at its prior, seeded again)', 'truth gate (step grid)')

    def apply_params(self, changed: set[str]) -> None:
        scheduler = getattr(self.tracker, 'scheduler', None)
        if 'delta' in changed and isinstance(scheduler, CovarianceScheduler):  # eq. 7 from the next step on
            scheduler.delta = float(self.p.delta)

    # -- inputs ---------------------------------------------------------------------------
    def _on_truth(self, msg: Odometry) -> None:
        key = stamp_to_ns(msg.header.stamp)
        reason = (odometry_problem(msg, KNOWN_FRAMES) or odometry_bounds_problem(msg, pose_covariance=False)
                  or stamp_problem(key * 1e-9, clock_now(self.get_clock().now().nanoseconds),
                                   InputPolicy(lead=self.p.stamp_lead))
                  or self.gate.problem(key))
        if reason:
            self.rejected += 1
            self.refuse(SONAR_TRUTH, reason)
            return
        _, x, _ = odometry_to_cv_state(msg)
        self.last_truth = self._clock_s()
        for k, key_k, x_true in self.gate.add_truth(key, x):
            if self.p.max_time > 0 and k * self.p.period > self.p.max_time + 1e-9:
                return
            self._step(k, key_k, x_true)
        stalled = self.gate.stalled()
        if stalled is not None:
            self.get_logger().warning(f'waiting for {self.sub_truth.topic_name} stamped {stalled} ns (lost?); '
                                      f'{len(self.gate.truth)} later truths are held')

    def _clock_s(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def _check_waiting(self) -> None:
        now = self._clock_s()
        if self.last_truth is None or now < self.last_truth:  # the clock started (0 -> /clock) or went back
            self.last_truth = now or None
            return
        if now - self.last_truth >= WAIT_WARN:
            self.get_logger().warning(f'no truth on {self.sub_truth.topic_name} for {WAIT_WARN:g} s '
                                      '(is smart_target running?)', throttle_duration_sec=60.0)

    # -- one step -------------------------------------------------------------------------
    def _step(self, k: int, key: int, x_true: np.ndarray) -> None:
        """Step k on the truth stamped ``key`` [ns]: every message carries that exact stamp."""
        self.k = k
        t, stamp = key * 1e-9, ns_to_stamp(key)
        obs_state = self.trajectory.state(k * self.p.period)  # trajectory time since step 0
        obs_xy = obs_state[[0, 2]]
        mode = self.tracker.next_mode
        z = simulate_measurement(self.noise_rng, x_true, obs_xy, mode, self.sonar)
        est = self.tracker.step(z, mode, obs_xy)
        if mode is SensorMode.ACTIVE:
            self.pings += 1
            ping = PointStamped()
            ping.header.frame_id = FRAME_MAP
            ping.point.x, ping.point.y = float(obs_xy[0]), float(obs_xy[1])
            self.pub_ping.publish(_stamped(ping, stamp))
        self.pub_est.publish(_stamped(cv_state_to_odometry(t, est.mean, est.cov, FRAME_MAP, self.p.track_id), stamp))
        self.pub_particles.publish(_stamped(positions_to_pose_array(t, self.tracker.particles[:, [0, 2]]), stamp))
        distance = None
        if isinstance(self.tracker.scheduler, CovarianceScheduler):
            distance = self.tracker.scheduler.distance(est.cov)
        mode_rec = SonarMode(est.mode.value, est.next_mode.value, est.k, est.ess, distance)
        status = mode_rec.to_status(f'{self.get_name()}/sensor_mode', DIAG_OK, est.mode.value)
        self.pub_mode.publish(_stamped(diagnostic_array(t, [status]), stamp))
        self.pub_markers.publish(_stamped(estimate_markers(t, est.mean, est.cov), stamp))
        odom = _stamped(cv_state_to_odometry(t, obs_state, np.zeros((4, 4)), FRAME_MAP, self.p.observer_id), stamp)
        self.send_transforms(odometry_transform(odom))
        self.pub_odom.publish(odom)  # last: the target's step k+1 waits for it


def _stamped(msg, stamp):
    """``msg`` (or each marker of a MarkerArray) with the exact stamp: a float of epoch seconds loses nanoseconds."""
    for m in getattr(msg, 'markers', None) or [msg]:
        m.header.stamp = stamp
    return msg
