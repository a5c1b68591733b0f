"""``rfid_guidance``: the particle-filter guidance of the handheld RFID reader (the RFID paper's Sections IV–VII).

Wraps ``track_core.rfid.guidance.RfidGuidance``: it consumes the step results of ``rfid_reader``
(``/rfid/step``) and publishes
- ``/rfid/command`` (RfidCommand): the next action, TURN by an angle, MOVE one step or DONE:
  ``seq``, ``kind``, ``angle`` (rad, + = left), ``angle_deg``, ``repeat``, ``reason``;
- after each filter update: ``/rfid/particles`` (PoseArray of (x, y, a) in ``rfid_pf``, tag at the
  origin); after each usable result: ``/rfid/tag_estimate`` (PointStamped in ``rfid_user``, x
  forward, y left: the tag at the weighted mean distance and the suggested bearing) and ``/tf``
  rfid_user → rfid_pf (the inverse of ``RfidGuidance.user_pose``, fixing the frame's free rotation);
- ``/rfid/found`` (RfidFound) once, when a result reports the user at the tag; then DONE.
The tag's side becoming unknown or known is logged (``TagSides.describe``, ``tag_sides``). After
``max_steps`` MOVE results (repeats included) the search fails: DONE with the reason.

Bad input (``protocol.step_result_problem``, a malformed message): ONE warning line, the filter and
the turn sum unchanged, the step repeated (``repeat``, new ``seq``; after ``max_repeats`` lost MOVEs,
TURN by π). A copy of a used result is dropped silently; a ``seq`` ahead is refused
(``TrackNode.refuse``). Command loop (``track_core.rfid.delivery.CommandLoop``): every ``period`` of node time the node
sends the first command (MOVE, seq 1) once ``/rfid/step`` has a publisher, and re-sends the pending
command after ``resend_after`` node seconds; each result is handled in its callback and the next
command published at once. Seeds: the filter draws from the second of ``SeedSequence(seed).spawn(2)``
(the reader the first), so the pair reproduces ``run_search(world, pf, default_rng(seed),
max_steps)`` exactly. A clock jump (``base.timejump``) starts a new search (``reset_time_state``).

``motion_source`` odometry (a reader carried by a robot): a MOVE's motion over [stamp − duration, stamp]
comes from ``/odom`` (REP-105, the reader at ``reader_pose`` in base_frame; ``track_core.rfid.odometry``);
not covered within ``odom_wait``: unusable, repeated (``odom_gaps``). Bad Odometry is refused, changing nothing.
Parameters are checked at start: ``n_particles`` < 1 or any value out of range stops the node.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from geometry_msgs.msg import PointStamped, PoseArray
from nav_msgs.msg import Odometry

from track_core.filters import invert_pose
from track_core.rfid.delivery import CommandLoop, Tick, Use
from track_core.rfid.guidance import MAX_REPEATS, RfidGuidance
from track_core.rfid.odometry import ReaderOdometry
from track_core.rfid.pf import SUGGESTION_RULES, WEIGHTINGS, PFParams
from track_core.rfid.protocol import Command, CommandKind, StepResult, step_result_problem
from track_core.rfid.search import MAX_STEPS
from track_msgs.msg import RfidCommand as RfidCommandMsg
from track_msgs.msg import RfidFound as RfidFoundMsg
from track_msgs.msg import RfidStep as RfidStepMsg
from track_msgs_py.odometry import positions_to_pose_array
from track_msgs_py.qos import ESTIMATE_QOS, SENSOR_QOS
from track_msgs_py.records import RecordError
from track_msgs_py.records.landmarks import PlanarOdometry
from track_msgs_py.records.rfid import RfidCommand, RfidFound, read_step
from track_msgs_py.stamps import sec_to_stamp, stamp_to_sec
from track_msgs_py.tf import frame_pair_problem, planar_transform
from track_msgs_py.topics import (
    FRAME_BASE,
    FRAME_ODOM,
    RFID_COMMAND,
    RFID_FOUND,
    RFID_FRAME_PF,
    RFID_FRAME_USER,
    RFID_PARTICLES,
    RFID_STEP,
    RFID_TAG_ESTIMATE,
    SLAM_ODOM,
)
from track_msgs_py.validate import clock_now, odometry_bounds_problem, odometry_problem, stamp_problem
from track_nodes.base import ParameterError, TrackNode, param
from track_nodes.rfid.params import PhaseParams, pf_config, phase_model

_PF = PFParams()
MOTION_SOURCES = ('instruction', 'odometry')


@dataclass
class RfidGuidanceParams(PhaseParams):
    """Parameters of ``rfid_guidance``."""

    seed: int = param(0, 'seed; the filter draws use the second of SeedSequence(seed).spawn(2)', 0, 2**31 - 1)
    n_particles: int = param(_PF.n_particles, 'number of particles N (Table I: 10-1000)', 1, 10_000_000)
    s_step: float = param(_PF.s_step, 'commanded step length (§VI: 0.5 m) [m]', 1e-3, 10.0)
    s_r: float = param(_PF.s_r, 'step error std s_r of the motion model (§VI: 0.1 m) [m]', 0.0, 10.0)
    s_a_deg: float = param(math.degrees(_PF.s_a), 'heading error std per step s_a (§VI: 11.5°) [deg]', 0.0, 180.0)
    beam_width_deg: float = param(math.degrees(_PF.beam_width), 'beam width assumed at the start (tag inside it) [deg]',
                                  1e-3, 360.0)
    suggestion: str = param(_PF.suggestion, 'turn rule: mean (eq. 24, circular), side, auto (track_core.rfid.pf)',
                            choices=SUGGESTION_RULES)
    weighting: str = param(_PF.weighting, 'f_w: inverse_square (Section V) or gaussian (track_core.rfid.pf)',
                           choices=WEIGHTINGS)
    reinit_factor: float = param(_PF.reinit_factor or 0.0, 're-initialise when min |m| > factor · m₀; 0 = never',
                                 0.0, 1e6)
    max_repeats: int = param(MAX_REPEATS, 'unusable MOVEs in a row before asking for a half turn', 1, 1000)
    max_steps: int = param(MAX_STEPS, 'MOVE results (repeats included) before the search ends as a failure',
                           1, 1_000_000, live=True)
    period: float = param(0.1, 'timer of the first command and of re-sends [node s]', 1e-3, 60.0, live=True)
    resend_after: float = param(2.0, 're-send the pending command after this long without its answer [node s]',
                                1e-3, 3600.0, live=True)
    motion_source: str = param('instruction', 'motion of a MOVE: instruction (s_step and the reported turns, the '
                               'paper) or odometry (a reader carried by a robot: nav_msgs/Odometry on /odom)',
                               choices=MOTION_SOURCES)
    odom_frame: str = param(FRAME_ODOM, "odometry: the robot's odometry frame (REP-105), header.frame_id of /odom")
    base_frame: str = param(FRAME_BASE, "odometry: the robot's body frame, child_frame_id of /odom")
    reader_pose: list[float] = param([0.0, 0.0, 0.0], 'odometry: the reader in base_frame [x m ahead, y m left, '
                                     'yaw rad]')
    odom_wait: float = param(1.0, 'odometry: a MOVE result waits this long for odometry at or after its end, then '
                             'the step is refused and repeated [node s]', 0.0, 3600.0, live=True)


class RfidGuidanceNode(TrackNode):
    DEFAULT_NAME = 'rfid_guidance'
    Params = RfidGuidanceParams
    p: RfidGuidanceParams  # the declared parameters (base/params.py)

    def setup(self) -> None:
        p = self.p
        try:
            self._start_run()
        except ValueError as exc:
            raise ParameterError(f'invalid guidance parameters: {exc}') from None
        problem = self.odo and frame_pair_problem(p.odom_frame, p.base_frame)
        if problem:
            raise ParameterError(f'parameters odom_frame={p.odom_frame!r}, base_frame={p.base_frame!r}: {problem}')
        self.warnings: list[str] = []            # the bad-input warnings, in order
        self.pub_cmd = self.create_publisher(RfidCommandMsg, RFID_COMMAND, ESTIMATE_QOS)
        self.pub_particles = self.create_publisher(PoseArray, RFID_PARTICLES, SENSOR_QOS)
        self.pub_estimate = self.create_publisher(PointStamped, RFID_TAG_ESTIMATE, ESTIMATE_QOS)
        self.pub_found = self.create_publisher(RfidFoundMsg, RFID_FOUND, ESTIMATE_QOS)
        self.advertise_transforms()
        self.sub_step = self.create_subscription(RfidStepMsg, RFID_STEP, self._on_step, ESTIMATE_QOS)
        if self.odo is not None:
            self.sub_odom = self.create_subscription(Odometry, SLAM_ODOM, self._on_odom, ESTIMATE_QOS)
        self.timer = self.create_timer(p.period, self._tick)

    def _start_run(self) -> None:
        """A new search: the filter seeded again, no command pending (the first is sent at the next tick)."""
        p = self.p
        _, pf_ss = np.random.SeedSequence(p.seed).spawn(2)
        self.guide = RfidGuidance(pf_config(p), phase_model(p), np.random.default_rng(pf_ss), log_warnings=False,
                                  max_repeats=p.max_repeats)
        self.loop = CommandLoop(p.resend_after, p.max_steps)  # pending command, re-sends (track_core.rfid.delivery)
        self.cmd_msg: RfidCommandMsg | None = None  # re-sent unchanged (same seq, same stamp)
        self.found = False
        self.turns = 0                           # usable TURN results
        self.tag_sides = None                    # the last filter update's mirror modes (module doc)
        self.odo = ReaderOdometry(p.reader_pose) if p.motion_source == 'odometry' else None
        self.held: tuple[StepResult, float, float, float] | None = None  # MOVE waiting for odometry: t0, t1, since
        self.odom_gaps = 0                       # MOVEs refused: odometry did not cover them within odom_wait

    def reset_time_state(self) -> tuple[str, ...]:
        """A clock jump (a replayed run starting again, a simulator reset): a new search from seq 1."""
        self._start_run()
        return ('particle filter (seeded again)', 'command loop (resend timer, seq)',
                *(('odometry (poses, the MOVE waiting for them)',) if self.odo is not None else ()))

    def apply_params(self, changed: set[str]) -> None:
        self.timer.timer_period_ns = round(self.p.period * 1e9)
        self.loop.resend_after, self.loop.max_steps = float(self.p.resend_after), int(self.p.max_steps)

    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    # -- sending --------------------------------------------------------------------------
    def _tick(self) -> None:
        self._take_held()
        action = self.loop.tick(self._now(), self.count_publishers(RFID_STEP) > 0)
        if action is Tick.START:
            self._send(self.guide.start())
        elif action is Tick.RESEND:
            self.get_logger().debug(f'no answer to {self.loop.cmd} yet: sending it again')
            self.pub_cmd.publish(self.cmd_msg)

    def _send(self, cmd: Command) -> None:
        t = self._now()
        self.loop.sent(cmd, t)
        self.cmd_msg = RfidCommand.from_command(cmd).to_msg(t)
        self.pub_cmd.publish(self.cmd_msg)

    # -- results --------------------------------------------------------------------------
    def _on_step(self, msg: RfidStepMsg) -> None:
        if self.loop.cmd is None:
            return  # nothing asked yet: not an answer
        res, seq = read_step(msg, self.loop.cmd)
        use = self.loop.on_result(seq, res.kind)
        if use is Use.AHEAD:  # answers no command: counting it would let a flood end the search
            self.refuse(RFID_STEP, f'seq: result #{seq} is ahead of the pending command #{self.loop.cmd.seq}')
        if use is not Use.USE:
            return  # a replayed answer already used, unsolicited, or after DONE
        if self.odo is not None and res.kind is CommandKind.MOVE and step_result_problem(res, self.loop.cmd) is None:
            t1 = stamp_to_sec(msg.header.stamp)
            self.held = (res, t1 - msg.duration, t1, self._now())   # its reads span [t0, t1]
            self._take_held()
        else:
            self._use(res)

    def _on_odom(self, msg: Odometry) -> None:
        """The robot's odometry (REP-105): checked, then its pose kept; refused with the reason, changing nothing."""
        p, odo = self.p, None
        reason = (odometry_problem(msg, {p.odom_frame}) or odometry_bounds_problem(msg, pose_covariance=False)
                  or (None if msg.child_frame_id == p.base_frame else
                      f'child_frame_id: {msg.child_frame_id!r}, expected base_frame {p.base_frame!r}'))
        try:
            odo = None if reason else PlanarOdometry.from_msg(msg)
        except RecordError as exc:
            reason = str(exc)
        reason = reason or (stamp_problem(odo.t, clock_now(self.get_clock().now().nanoseconds))
                            or self.odo.problem(odo.t))
        if reason:
            self.refuse(SLAM_ODOM, reason)
            return
        self.odo.add(odo.t, odo.pose)
        self._take_held()

    def _take_held(self) -> None:
        """The held MOVE with its measured motion once odometry covers it; unusable after ``odom_wait``."""
        if self.held is None:
            return
        res, t0, t1, since = self.held
        gap = self.odo.gap(t0, t1)
        if gap is not None and self._now() - since < self.p.odom_wait:
            return
        self.held = None
        if gap is None:
            self._use(res, (t0, t1))
        else:
            self.odom_gaps += 1
            self._use(replace(res, ok=False, reason=f'odometry does not cover the step: {gap}'))

    def _use(self, res: StepResult, span: tuple[float, float] | None = None) -> None:
        """Hand ``res`` to the core (with the motion odometry measured over ``span``), send the next command."""
        warned = bool(self.guide.sign_warning)
        reply = self.guide.on_step(res, None if span is None else self.odo.motion(*span))
        if span is not None and reply.accepted:
            self.odo.used(span[1])
        if self.guide.sign_warning and not warned:   # once per search: the convention check (guidance doc)
            self.get_logger().warning(self.guide.sign_warning)
            self.warnings.append(self.guide.sign_warning)
        if reply.warning is not None:
            self.warnings.append(f'{self.resolved(RFID_STEP)} #{res.seq}: {reply.warning}; filter state unchanged, '
                                 f'asking for {reply.command}')
            self.refuse(RFID_STEP, f'{reply.warning}; filter state unchanged, step repeated')  # counted, throttled
        elif res.kind is CommandKind.TURN:
            self.turns += 1
        t = self._now()
        if reply.accepted:
            self._publish_estimate(t, res.kind is CommandKind.MOVE)
        nxt = self.loop.next_command(reply.command, reply.found, res.found)
        if nxt.outcome == 'found':
            self.found = self.guide.found = True
            self._publish_found(t, res.seq)
        elif nxt.outcome == 'failed':
            self.get_logger().warning(f'search failed: {nxt.command.reason}')
        if nxt.command.kind is CommandKind.DONE:
            self.guide.pending = nxt.command
        self._send(nxt.command)

    def _publish_estimate(self, t: float, updated: bool) -> None:
        pf = self.guide.pf
        if not pf.initialized:
            return
        pf_in_user = invert_pose(self.guide.user_pose())
        if np.all(np.isfinite(pf_in_user)):
            self.send_transforms(planar_transform(t, RFID_FRAME_USER, RFID_FRAME_PF, *pf_in_user))
        if updated:
            P = pf.particles
            self.pub_particles.publish(positions_to_pose_array(t, P[:, :2], RFID_FRAME_PF, headings=P[:, 2]))
            sides, before = self.guide.tag_sides(), self.tag_sides
            if before is None or sides.unknown != before.unknown:   # one line per change of what is known
                self.get_logger().info(sides.describe())
            self.tag_sides = sides
        d, b = self.guide.tag_estimate()
        if math.isfinite(d) and math.isfinite(b):
            msg = PointStamped()
            msg.header.stamp, msg.header.frame_id = sec_to_stamp(t), RFID_FRAME_USER
            msg.point.x, msg.point.y = d * math.cos(b), d * math.sin(b)
            self.pub_estimate.publish(msg)

    def _publish_found(self, t: float, seq: int) -> None:
        pf, moves = self.guide.pf, self.loop.moves
        self.get_logger().info(f'tag found after {moves} steps and {self.turns} turns')
        self.pub_found.publish(RfidFound(seq, moves, self.turns, pf.n_updates, pf.n_resamples,
                                         pf.n_reinits).to_msg(t))
