"""``rfid_guidance``: the particle-filter guidance of the handheld RFID reader (the RFID paper's Sections IV–VII).

Wraps ``track_core.rfid.guidance.RfidGuidance``: it consumes the step results of ``rfid_reader``
(``/rfid/step``) and publishes

- ``/rfid/command`` (track_msgs/RfidCommand, ``track_msgs_py.records.rfid.RfidCommand``): the next
  action, TURN by an angle or MOVE one step, or DONE at the end: ``seq``, ``kind``, ``angle`` (rad,
  + = left), ``angle_deg``, ``repeat`` (true when it repeats a step whose result was unusable), ``reason``;
- after each filter update (a usable MOVE): ``/rfid/particles`` (geometry_msgs/PoseArray, the
  particles (x, y, a) in the filter's frame ``rfid_pf``, tag at the origin, orientation = a);
- after each usable result: ``/rfid/tag_estimate`` (geometry_msgs/PointStamped in ``rfid_user``,
  x forward, y left): the tag at distance d (weighted mean of |pᵢ|) and bearing b (the suggested
  turn minus the turns made since the last MOVE) from the user;
- after each usable result: ``/tf`` rfid_user → rfid_pf, the inverse of the user's estimated pose in
  the filter's frame (``RfidGuidance.user_pose``), so particles drawn in ``rfid_pf`` sit around the
  user wherever the reader places ``rfid_user`` in map (the filter frame's rotation is a free gauge:
  this estimate fixes it, as a localiser's map → odom does);
- ``/rfid/found`` (track_msgs/RfidFound: the result's seq and the search's counters) once, when a step
  result reports the user at the tag. The search then ends with DONE.

The tag's side of the walking line: a straight walk cannot tell the tag from its mirror image
(``track_core.rfid.pf``, ``tag_sides``), so ``/rfid/tag_estimate`` may be on the wrong side. After each
filter update the node logs one info line when the side becomes unknown or known
(``TagSides.describe``: while unknown, both modes with their probabilities); ``tag_sides`` holds the
last report.

The search also ends, as a failure, after ``max_steps`` MOVE results (repeated ones included: the
count of ``track_core.rfid.search.run_search``), with DONE and the reason.

Bad input (the core's rule, ``protocol.step_result_problem``): a step result with a NaN dφ or turn,
an empty phase stream (``n_reads`` 0), a reader failure such as "signal lost", a result for another
command, or a malformed message (an unknown kind, a non-finite duration, ``records.rfid.RfidStep``),
gets ONE warning log line naming the problem; the filter and the turn sum stay exactly as they
were, and the next command repeats the step (``repeat`` true, new
``seq``; after ``max_repeats`` lost MOVEs in a row, TURN by π, see the core). A copy of a result
already used (``seq`` below the pending command's: the reader re-publishes its answer when a
command is re-sent) is no bad input: it is dropped silently. A result whose ``seq`` is ahead of the
pending command's answers nothing: it is refused (``TrackNode.refuse``) and changes nothing, so a
flood of them cannot spend the ``max_steps``.

Command/response loop (``track_core.rfid.delivery.CommandLoop``), deterministic for a seed. Every
``period`` of node time (a /clock-driven timer under ``use_sim_time``) the node

1. sends the first command (MOVE, seq 1) once the reader is seen (``/rfid/step`` has a publisher).
   Nothing is sent before that timer runs, so under the launcher nothing is published before the
   clock starts (the recorder is subscribed by then);
2. re-sends the pending command, unchanged, when it has been waiting for ``resend_after`` node
   seconds (a command lost to a discovery race is not a dead end; the reader answers each seq once
   and replays that answer for a copy).

Each new result is handled in its callback and the next command is published at once. Its content
depends only on the results received in order, and those only on the reader's seed. Seeds: the
filter draws from the second of ``SeedSequence(seed).spawn(2)`` (the reader takes the first), so
the node pair with the same ``seed`` reproduces ``run_search(world, pf, default_rng(seed),
max_steps)`` exactly.

A jump of the clock (``track_nodes.base.timejump``) starts a new search (``reset_time_state``): the
resend timer counts node time and the reader numbers its answers from seq 1 again after a restart.

Parameters are checked at start: ``n_particles`` < 1 or any value out of range stops the node
with one line.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from geometry_msgs.msg import PointStamped, PoseArray

from track_core.filters import invert_pose
from track_core.rfid.delivery import CommandLoop, Tick, Use
from track_core.rfid.guidance import RfidGuidance
from track_core.rfid.pf import SUGGESTION_RULES, WEIGHTINGS, PFParams
from track_core.rfid.phase import PhaseModel
from track_core.rfid.protocol import Command, CommandKind
from track_msgs.msg import RfidCommand as RfidCommandMsg
from track_msgs.msg import RfidFound as RfidFoundMsg
from track_msgs.msg import RfidStep as RfidStepMsg
from track_msgs_py.odometry import positions_to_pose_array
from track_msgs_py.qos import ESTIMATE_QOS, SENSOR_QOS
from track_msgs_py.records.rfid import RfidCommand, RfidFound, read_step
from track_msgs_py.stamps import sec_to_stamp
from track_msgs_py.tf import planar_transform
from track_msgs_py.topics import (
    RFID_COMMAND,
    RFID_FOUND,
    RFID_FRAME_PF,
    RFID_FRAME_USER,
    RFID_PARTICLES,
    RFID_STEP,
    RFID_TAG_ESTIMATE,
)
from track_nodes.base import ParameterError, TrackNode, param
from track_nodes.rfid.params import PhaseParams

_PF = PFParams()


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
    reinit_factor: float = param(3.0, 're-initialise when min |m| > factor · m₀; 0 = never', 0.0, 1e6)
    max_repeats: int = param(2, 'unusable MOVEs in a row before asking for a half turn', 1, 1000)
    max_steps: int = param(200, 'MOVE results (repeats included) before the search ends as a failure',
                           1, 1_000_000, live=True)
    period: float = param(0.1, 'timer of the first command and of re-sends [node s]', 1e-3, 60.0, live=True)
    resend_after: float = param(2.0, 're-send the pending command after this long without its answer [node s]',
                                1e-3, 3600.0, live=True)


def pf_params(p) -> PFParams:
    try:
        return PFParams(n_particles=p.n_particles, s_step=p.s_step, s_r=p.s_r, s_a=math.radians(p.s_a_deg),
                        beam_width=math.radians(p.beam_width_deg), suggestion=p.suggestion, weighting=p.weighting,
                        reinit_factor=p.reinit_factor if p.reinit_factor > 0 else None)
    except ValueError as exc:
        raise ParameterError(f'invalid filter parameters: {exc}') from None


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
        self.warnings: list[str] = []            # the bad-input warnings, in order
        self.pub_cmd = self.create_publisher(RfidCommandMsg, RFID_COMMAND, ESTIMATE_QOS)
        self.pub_particles = self.create_publisher(PoseArray, RFID_PARTICLES, SENSOR_QOS)
        self.pub_estimate = self.create_publisher(PointStamped, RFID_TAG_ESTIMATE, ESTIMATE_QOS)
        self.pub_found = self.create_publisher(RfidFoundMsg, RFID_FOUND, ESTIMATE_QOS)
        self.advertise_transforms()
        self.sub_step = self.create_subscription(RfidStepMsg, RFID_STEP, self._on_step, ESTIMATE_QOS)
        self.timer = self.create_timer(p.period, self._tick)

    def _start_run(self) -> None:
        """A new search: the filter seeded again, no command pending (the first is sent at the next tick)."""
        p = self.p
        _, pf_ss = np.random.SeedSequence(p.seed).spawn(2)
        phase = PhaseModel.with_wrap(p.wrap, carrier_hz=p.carrier_hz, s_theta=math.radians(p.s_theta_deg),
                                     convention=p.convention)
        self.guide = RfidGuidance(pf_params(p), phase, np.random.default_rng(pf_ss), log_warnings=False,
                                  max_repeats=p.max_repeats)
        self.loop = CommandLoop(p.resend_after, p.max_steps)  # pending command, re-sends (track_core.rfid.delivery)
        self.cmd_msg: RfidCommandMsg | None = None  # re-sent unchanged (same seq, same stamp)
        self.found = False
        self.turns = 0                           # usable TURN results
        self.tag_sides = None                    # the last filter update's mirror modes (module doc)

    def reset_time_state(self) -> tuple[str, ...]:
        """A clock jump (a replayed run starting again, a simulator reset): a new search from seq 1."""
        self._start_run()
        return ('particle filter (seeded again)', 'command loop (resend timer, seq)')

    def apply_params(self, changed: set[str]) -> None:
        self.timer.timer_period_ns = round(self.p.period * 1e9)
        self.loop.resend_after, self.loop.max_steps = float(self.p.resend_after), int(self.p.max_steps)

    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    # -- sending --------------------------------------------------------------------------
    def _tick(self) -> None:
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
        warned = bool(self.guide.sign_warning)
        reply = self.guide.on_step(res)
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
