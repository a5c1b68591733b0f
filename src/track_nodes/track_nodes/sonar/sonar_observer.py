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
from dataclasses import dataclass

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PointStamped, PoseArray
from nav_msgs.msg import Odometry
from visualization_msgs.msg import MarkerArray

from track_core.sonar import (
    DEFAULT_P_D,
    CovarianceScheduler,
    ObserverTrajectory,
    Scenario,
    SensorMode,
    SmartTargetParams,
    SonarParams,
    desired_covariance,
    make_tracker,
    simulate_measurement,
)
from track_core.sonar.lockstep import TruthGate
from track_core.sonar.scenario import DEFAULT_LEGS
from track_core.sonar.scheduler import DELTA
from track_core.sonar.sspf import PREDICTIONS, TRACKERS
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
from track_nodes.base import ParameterError, TrackNode, param

TARGET_MODELS = ('cv', 'smart')
_SMART = SmartTargetParams()


@dataclass
class SonarObserverParams:
    """Parameters of ``sonar_observer``."""

    seed: int = param(0, 'seed of the measurement noise and of the particle filter (two spawned streams)', 0, 2**31 - 1)
    tracker: str = param('ss-pf', 'ss-pf: eq. 7 scheduling; papf: passive only; acpf: active only', choices=TRACKERS)
    delta: float = param(DELTA, 'threshold δ of eq. 7 (Table 1: 5) [m²]', 0.0, 1e12, live=True)
    P_D: list[float] = param([float(v) for v in np.diag(DEFAULT_P_D)], 'desired covariance P_D of eq. 7 in [x, vx, y, '
                             'vy]: 4 values (diagonal) or 16 (row-major 4x4), symmetric PSD')
    metric: str = param('spectral', 'eq. 7 distance: spectral ‖P_D − Cov‖₂ (paper) or excess λmax(Cov − P_D)',
                        choices=('spectral', 'excess'))
    initial_pings: int = param(1, 'active steps at the start before eq. 7 decides (Algorithm 3: 1; '
                               'track_core.sonar.scheduler)', 1, 1000)
    target_model: str = param('cv', "the filter's target model: cv (eqs. 1-4) or smart (the target evades when it "
                              'hears a ping; the model_* parameters)', choices=TARGET_MODELS)
    prediction: str = param('unscented', 'smart model: each particle predicted through the manoeuvre by its sigma '
                            'points (unscented) or by its mean with F P Fᵀ + Q (linear)', choices=PREDICTIONS)
    model_p_max: float = param(_SMART.p_max, 'smart model: detection probability of a ping at close range', 0.0, 1.0)
    model_r_50: float = param(_SMART.r_50, 'smart model: range at which a ping is heard with probability p_max/2 [m]',
                              1e-3, 1e7)
    model_width: float = param(_SMART.width, 'smart model: width of the logistic fall-off of P_det [m]', 1e-3, 1e7)
    model_evade_speed: float = param(_SMART.evade_speed, 'smart model: speed while evading [m/s]', 0.0, 1e3)
    model_max_turn_rate_deg: float = param(math.degrees(_SMART.max_turn_rate), 'smart model: bounded turn rate '
                                           '[deg/s]', 0.0, 360.0)
    model_max_accel: float = param(_SMART.max_accel, 'smart model: bounded speed change [m/s²]', 0.0, 1e3)
    model_quiet_period: float = param(_SMART.quiet_period, 'smart model: time without a heard ping before cruising '
                                      'again [s]', 0.0, 1e6)
    n_particles: int = param(200, 'number of particles N (Table 1: 200)', 1, 1_000_000)
    regularize: bool = param(True, 'Liu-West move after resampling (track_core.sonar.sspf; not in the paper)')
    period: float = param(1.0, 'sampling period T (Table 1: 1 s) [s]', 1e-3, 60.0)
    q_s: float = param(1.0, 'process-noise intensity q_s of the filter model (Table 1: 1) [m²/s³]', 1e-9, 1e3)
    sigma_b_deg: float = param(1.0, 'bearing noise std σ_b (Table 1: 1°) [deg]', 1e-6, 180.0)
    sigma_d: float = param(5.0, 'range noise std σ_d of the active sonar (Table 1: 5 m) [m]', 1e-6, 1e6)
    prior_mean: list[float] = param([300.0, 12.25, 300.0, -12.25], 'prior mean m₀ = [x, vx, y, vy] at t = 0 [m, m/s]')
    prior_pos_std: float = param(20.0, 'prior position std per axis [m]', 1e-6, 1e6)
    prior_vel_std: float = param(2.0, 'prior velocity std per axis [m/s]', 1e-6, 1e6)
    start: list[float] = param([0.0, 0.0], 'observer start position [x, y] in map [m]')
    speed: float = param(10.0, 'observer speed [m/s]', 0.0, 1e3)
    heading0_deg: float = param(90.0, 'observer initial heading, clockwise from north [deg]', -360.0, 360.0)
    legs: list[float] = param([float(v) for leg in DEFAULT_LEGS for v in leg], 'observer legs, flat [duration s, turn '
                              'rate deg/s, ...]; the last leg extends past its duration')
    max_time: float = param(0.0, 'stop after step k with k·T > max_time (trajectory time) [s]; 0 = never', 0.0, 1e9)
    track_id: str = param('sonar_track', 'child_frame_id of the estimate')
    observer_id: str = param('sonar_observer', 'child_frame_id of the observer odometry')
    stamp_lead: float = param(3.0, 'look-ahead tolerance: refuse truths stamped more than this ahead of the node clock '
        '(a few periods; also a late truth of a run before a clock jump) [s]', 1e-3, 1e9, live=True)


WAIT_WARN = 10.0  # s of the node's clock (sim time under use_sim_time) without a truth before a warning


def _p_d(values) -> np.ndarray:
    v = np.asarray(values, dtype=float)
    if v.size not in (4, 16):
        raise ParameterError(f'parameter P_D has {v.size} values: allowed 4 (diagonal) or 16 (row-major 4x4)')
    try:
        return desired_covariance(v if v.size == 4 else v.reshape(4, 4))
    except ValueError as exc:
        raise ParameterError(f'parameter P_D={v.tolist()!r} is invalid ({exc}): allowed a symmetric PSD '
                             'matrix') from None


def target_model_of(p: SonarObserverParams) -> SmartTargetParams | None:
    """The SS-PF's ``target_model`` of the parameters: None for ``cv``, the ``model_*`` values for ``smart``."""
    if p.target_model == 'cv':
        return None
    return SmartTargetParams(p_max=p.model_p_max, r_50=p.model_r_50, width=p.model_width,
                             evade_speed=p.model_evade_speed, max_turn_rate=math.radians(p.model_max_turn_rate_deg),
                             max_accel=p.model_max_accel, quiet_period=p.model_quiet_period)


class SonarObserverNode(TrackNode):
    DEFAULT_NAME = 'sonar_observer'
    Params = SonarObserverParams
    p: SonarObserverParams  # the declared parameters (base/params.py)

    def setup(self) -> None:
        p = self.p
        P_D = _p_d(p.P_D)
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
