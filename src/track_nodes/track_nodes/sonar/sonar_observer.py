"""``sonar_observer``: the SS-PF of the sonar paper on a real sonar's contacts and the own ship's navigation.

Inputs (``sonar_sim`` stands in for both): ``/sonar/contacts`` (``track_msgs/SonarContact``: a
listen (bearing) or ping (bearing and range) with its stds, the R of eqs. 5-6; bearing REP-103 in
``world_frame`` or ``body_frame``, another frame refused) and ``/sonar/observer/odom``
(nav_msgs/Odometry, REP-105, interpolated to each contact's stamp).

``track_core.sonar.contacts.ContactSequencer`` makes the filter steps: a contact is a step at its
own stamp (eqs. 3-4 over the actual interval); a period T without a contact is a predict-only step
(``predictions``; with ``coast_after`` also on the node clock); a contact waits up to ``nav_wait``
for a later fix; a contact not after the filter's time or over ``stamp_lead`` ahead is refused. The
prior (``prior_mean``, stds) is the target one period before the first contact.

Outputs per step, stamped with the step's time: ``/sonar/estimate`` (Odometry, ``child_frame_id`` =
``track_id``), ``/sonar/particles`` (PoseArray; one pose while merged), ``/sonar/mode``
(SonarFilterStatus: the reading taken, eq. 7's request, ESS, ``distance`` = ‖P_D − Cov‖),
``/sonar/markers`` (2σ ellipse), and last ``/sonar/mode_command`` (latched; also once at start,
stamped 0). Seeded (the second of ``SeedSequence(seed).spawn(2)``): replayed contacts reproduce
every estimate bit for bit; a clock jump restarts at the prior.

``target_model``: ``cv`` (eqs. 1-4) or ``smart`` (the node's ``model_*`` parameters, as
``config/maritime.yaml`` sets; ``prediction`` ``unscented`` or ``linear``). δ < 0, N < 1 or a P_D
not symmetric PSD (4 values: a diagonal; 16: row-major 4×4) stop the node with one line. In full:
docs/MODULES.md, "The sonar_observer node in full".
"""

from __future__ import annotations

import numpy as np
from geometry_msgs.msg import PoseArray
from nav_msgs.msg import Odometry
from visualization_msgs.msg import MarkerArray

from track_core.sonar import CovarianceScheduler, Scenario, SensorMode
from track_core.sonar.contacts import ContactSequencer, Dropped, Step
from track_msgs import msg as tm
from track_msgs_py.markers.sonar import estimate_markers
from track_msgs_py.odometry import cv_state_to_odometry, positions_to_pose_array
from track_msgs_py.qos import ESTIMATE_QOS, SENSOR_QOS, STATIC_QOS
from track_msgs_py.records import RecordError
from track_msgs_py.records.sonar import SonarFilterStatus, contact_from_msg, fix_from_odometry, mode_command_to_msg
from track_msgs_py.stamps import ns_to_stamp, stamp_to_ns
from track_msgs_py.topics import (
    SONAR_CONTACTS,
    SONAR_ESTIMATE,
    SONAR_MARKERS,
    SONAR_MODE,
    SONAR_MODE_COMMAND,
    SONAR_OBSERVER,
    SONAR_PARTICLES,
)
from track_msgs_py.validate import (
    InputPolicy,
    clock_now,
    header_problem,
    odometry_bounds_problem,
    odometry_problem,
    stamp_problem,
)
from track_nodes.base import ParameterError, TrackNode
from track_nodes.sonar.observer_params import (
    SonarObserverParams,
    observer_tracker,
    scheduler_config,
    sonar_params,
    sspf_config,
)

WAIT_WARN = 10.0  # s of the node's clock (sim time under use_sim_time) without a contact before a warning
TICK = 0.1  # s of the node's clock between checks of held contacts and due periods


class SonarObserverNode(TrackNode):
    DEFAULT_NAME = 'sonar_observer'
    Params = SonarObserverParams
    p: SonarObserverParams  # the declared parameters (base/params.py)

    def setup(self) -> None:
        p = self.p
        m0 = np.asarray(p.prior_mean, dtype=float)
        if m0.shape != (4,) or not np.all(np.isfinite(m0)):
            raise ParameterError(f'parameter prior_mean={list(p.prior_mean)!r} is invalid: allowed 4 finite numbers')
        for name in ('world_frame', 'body_frame'):
            if not getattr(p, name) or getattr(p, name).startswith('/'):
                raise ParameterError(f'parameter {name}={getattr(p, name)!r} is invalid: allowed a frame name '
                                     '(not empty, no leading /)')
        if p.world_frame == p.body_frame:
            raise ParameterError(f'parameters world_frame and body_frame are both {p.world_frame!r}: allowed two '
                                 'different frames')
        self.sonar = sonar_params(p)
        sspf_config(p), scheduler_config(p)   # a bad value stops the node here, with one line
        self._prior = (m0, Scenario(params=self.sonar, prior_pos_std=p.prior_pos_std,
                                         prior_vel_std=p.prior_vel_std).prior_cov)
        self.rejected = 0
        self.dropped = 0
        self.pub_est = self.create_publisher(Odometry, SONAR_ESTIMATE, ESTIMATE_QOS)
        self.pub_particles = self.create_publisher(PoseArray, SONAR_PARTICLES, SENSOR_QOS)
        self.pub_mode = self.create_publisher(tm.SonarFilterStatus, SONAR_MODE, ESTIMATE_QOS)
        self.pub_markers = self.create_publisher(MarkerArray, SONAR_MARKERS, ESTIMATE_QOS)
        self.pub_command = self.create_publisher(tm.SonarModeCommand, SONAR_MODE_COMMAND, STATIC_QOS)
        self._start_run()
        self.sub_nav = self.create_subscription(Odometry, SONAR_OBSERVER, self._on_nav, ESTIMATE_QOS)
        self.sub_contact = self.create_subscription(tm.SonarContact, SONAR_CONTACTS, self._on_contact, ESTIMATE_QOS)
        # On the node's clock: a slow lock-step run (sim time) waits on its sonar for long wall times.
        self.last_contact: float | None = self._clock_s() or None  # None: the sim clock has not started
        self.wait_timer = self.create_timer(WAIT_WARN, self._check_waiting)
        self.tick_timer = self.create_timer(TICK, self._tick)

    def _start_run(self) -> None:
        """A fresh run: the tracker at its prior with its Generator seeded, no contact or fix, the start request."""
        p, (m0, prior_cov) = self.p, self._prior
        _, filter_ss = np.random.SeedSequence(p.seed).spawn(2)
        self.tracker = observer_tracker(p, self.sonar, np.random.default_rng(filter_ss))
        self.tracker.initialize(m0, prior_cov)
        self.sequencer = ContactSequencer(self.tracker, round(p.period * 1e9), nav_wait_ns=round(p.nav_wait * 1e9),
                                          nav_max_age_ns=round(p.nav_max_age * 1e9),
                                          coast_after_ns=round(p.coast_after * 1e9))
        self.k = 0
        self.pings = 0  # active readings taken
        self.pub_command.publish(mode_command_to_msg(0, self.tracker.next_mode, None))

    def reset_time_state(self) -> tuple[str, ...]:
        """A new run (as a fresh node: a replayed run reproduces its estimates again)."""
        self._start_run()
        self.last_contact = self._clock_s()
        return ('tracker (at its prior, seeded again)', 'contacts and navigation')

    def apply_params(self, changed: set[str]) -> None:
        scheduler = getattr(self.tracker, 'scheduler', None)
        if 'delta' in changed and isinstance(scheduler, CovarianceScheduler):  # eq. 7 from the next step on
            scheduler.delta = float(self.p.delta)
        seq = self.sequencer
        seq.nav_wait_ns, seq.nav_max_age_ns = round(self.p.nav_wait * 1e9), round(self.p.nav_max_age * 1e9)
        seq.coast_after_ns = round(self.p.coast_after * 1e9)

    # -- inputs ---------------------------------------------------------------------------
    def _policy_problem(self, key: int) -> str | None:
        return stamp_problem(key * 1e-9, clock_now(self.get_clock().now().nanoseconds),
                             InputPolicy(lead=self.p.stamp_lead))

    def _on_nav(self, msg: Odometry) -> None:
        key = stamp_to_ns(msg.header.stamp)
        reason = (odometry_problem(msg, (self.p.world_frame,)) or odometry_bounds_problem(msg, pose_covariance=False)
                  or self._policy_problem(key))
        fix = None if reason else fix_from_odometry(msg)
        reason = reason or self.sequencer.nav.problem(fix)
        if reason:
            self.rejected += 1
            self.refuse(SONAR_OBSERVER, reason)
            return
        self._publish(self.sequencer.add_fix(fix, self._now_ns()))

    def _on_contact(self, msg: tm.SonarContact) -> None:
        key = stamp_to_ns(msg.header.stamp)
        frames = (self.p.world_frame, self.p.body_frame)
        reason = header_problem(msg.header, frames) or self._policy_problem(key)
        contact = None
        if not reason:
            try:
                contact = contact_from_msg(msg, relative=msg.header.frame_id == self.p.body_frame)
            except RecordError as exc:
                reason = str(exc)
        reason = reason or self.sequencer.contact_problem(contact)
        if reason:
            self.rejected += 1
            self.refuse(SONAR_CONTACTS, reason)
            return
        self.last_contact = self._clock_s()
        self._publish(self.sequencer.add_contact(contact, self._now_ns()))

    def _tick(self) -> None:
        if self.get_clock().now().nanoseconds > 0:  # sim time: nothing is due before the first /clock
            self._publish(self.sequencer.tick(self._now_ns()))

    def _now_ns(self) -> int:
        return self.get_clock().now().nanoseconds

    def _clock_s(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def _check_waiting(self) -> None:
        now = self._clock_s()
        if self.last_contact is None or now < self.last_contact:  # the clock started (0 -> /clock) or went back
            self.last_contact = now or None
            return
        if now - self.last_contact >= WAIT_WARN:
            self.get_logger().warning(f'no contact on {self.sub_contact.topic_name} for {WAIT_WARN:g} s '
                                      '(is the sonar driver or sonar_sim running?)', throttle_duration_sec=60.0)

    # -- one step -------------------------------------------------------------------------
    def _publish(self, results: list[Step | Dropped]) -> None:
        for r in results:
            if isinstance(r, Dropped):
                self.dropped += 1
                self.refuse(SONAR_CONTACTS, f'contact stamped {r.key} ns dropped: {r.reason}')
            else:
                self._step(r)

    def _step(self, step: Step) -> None:
        """Publish filter step ``step``: every message carries its exact stamp."""
        est, key = step.estimate, step.key
        self.k = est.k
        self.pings += step.contact is not None and step.contact.mode is SensorMode.ACTIVE
        t, stamp, world = key * 1e-9, ns_to_stamp(key), self.p.world_frame
        self.pub_est.publish(_stamped(cv_state_to_odometry(t, est.mean, est.cov, world, self.p.track_id), stamp))
        self.pub_particles.publish(_stamped(positions_to_pose_array(t, self.tracker.particles[:, [0, 2]], world),
                                            stamp))
        distance = None
        if isinstance(self.tracker.scheduler, CovarianceScheduler):
            distance = self.tracker.scheduler.distance(est.cov)
        status = SonarFilterStatus(est.mode, est.next_mode, step.contact is not None, est.k, est.ess, distance)
        self.pub_mode.publish(status.to_msg(key))
        self.pub_markers.publish(_stamped(estimate_markers(t, est.mean, est.cov, world), stamp))
        self.pub_command.publish(mode_command_to_msg(key, est.next_mode, distance))  # last: the sonar waits for it


def _stamped(msg, stamp):
    """``msg`` (or each marker of a MarkerArray) with the exact stamp: a float of epoch seconds loses nanoseconds."""
    for m in getattr(msg, 'markers', None) or [msg]:
        m.header.stamp = stamp
    return msg
