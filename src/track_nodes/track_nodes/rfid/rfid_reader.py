"""``rfid_reader``: the simulated user holding the handheld UHF RFID reader (the RFID paper's Section VI).

The reader side of the step-by-step protocol of ``track_core.rfid.protocol``: it performs each
command that ``rfid_guidance`` publishes on ``/rfid/command`` with
``track_core.rfid.world.SimReader`` (the user turns or walks one step with the paper's worst-case
errors, the reader reads the tag ~300 times a second and processes the MOVE's phase stream into dφ)
and publishes, in this order,
- ``/rfid/phase`` (PointCloud2 in ``map``, MOVE only, ``records.rfid.RfidPhase``): the raw wrapped
  reads, float32 ``x``, ``y``, ``z`` (the reader at the read: truth, for display), ``t`` (s since
  the step started), ``phase`` (rad, in (0, P]), ``rssi`` (dBm), ``carrier_mhz``;
- ``/rfid/user/pose`` (PoseStamped in ``map``, tag at the origin) and ``/rfid/user/status``
  (RfidUserStatus): truth for evaluation only; also ``/tf`` map → rfid_user and ``/tf_static``
  rfid_user → <node name> (identity);
- ``/rfid/step`` (RfidStep, last): the fields of ``StepResult`` plus ``duration``
  (``records.rfid.RfidStep``; an unknown dφ, turn or dφ std has its ``*_known`` false). The phase
  cloud and the step result of one MOVE carry the same stamp.

One answer per command ``seq`` (``track_core.rfid.delivery.AnswerCache``): a repeated seq gets the
cached result, an older one is ignored; an unknown kind, seq 0, a non-finite angle or a seq over
``SEQ_WINDOW`` ahead is refused. After DONE nothing more is performed. With ``time_scale`` > 0 the
answer waits the simulated duration (the walk, or ``turn_read_s``) × ``time_scale`` of node time
(timer ``tick``); the content depends only on the seed and the commands. Seeds: the first of
``SeedSequence(seed).spawn(2)`` (the guidance takes the second), so the pair replays
``run_search(world, pf, default_rng(seed), max_steps)``; ``random_start`` false fixes the start. Bad
parameters stop the node with one line. In full: docs/MODULES.md, "The rfid_reader node in full".
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import PointCloud2

from track_core.rfid.delivery import AnswerCache, Verdict
from track_core.rfid.protocol import Command, CommandKind
from track_core.rfid.signal import UnwrapConfig
from track_core.rfid.world import SimReader, WorldParams, office_obstacles
from track_msgs.msg import RfidCommand as RfidCommandMsg
from track_msgs.msg import RfidStep as RfidStepMsg
from track_msgs.msg import RfidUserStatus as RfidUserStatusMsg
from track_msgs_py.qos import ESTIMATE_QOS
from track_msgs_py.records import RecordError
from track_msgs_py.records.rfid import RfidPhase, RfidStep, RfidUserStatus, read_command
from track_msgs_py.stamps import sec_to_stamp
from track_msgs_py.tf import planar_transform, pose_transform
from track_msgs_py.topics import (
    FRAME_MAP,
    RFID_COMMAND,
    RFID_FRAME_USER,
    RFID_PHASE,
    RFID_STEP,
    RFID_USER_POSE,
    RFID_USER_STATUS,
)
from track_nodes.base import ParameterError, TrackNode, param
from track_nodes.rfid.params import PhaseParams, phase_model

_W = WorldParams()


@dataclass
class RfidReaderParams(PhaseParams):
    """Parameters of ``rfid_reader``."""

    seed: int = param(0, 'seed; the world/user draws use the first of SeedSequence(seed).spawn(2)', 0, 2**31 - 1)
    start_distance: float = param(_W.start_distance, 'distance of the random start from the tag (§VI: 10 m) [m]',
                                  1e-3, 1e3)
    random_start: bool = param(True, 'start start_distance away in a random direction (false: use start)')
    start: list[float] = param([10.0, 0.0, 180.0], 'fixed start [x m, y m, facing deg from +x] (map, tag at the '
                               'origin)')
    beam_width_deg: float = param(math.degrees(_W.beam_width), 'antenna half-power beam width (§VI: 180°, real 68°) '
                                  '[deg]', 1e-3, 360.0)
    max_range: float = param(_W.max_range, 'read range [m]', 1e-3, 1e3)
    back_lobe_range: float = param(_W.back_lobe_range, 'range of the back/side lobes [m]', 0.0, 1e3)
    read_rate: float = param(_W.read_rate, 'reads per second while the tag is read (Poisson) [1/s]', 1e-3, 1e5)
    outlier_prob: float = param(_W.outlier_prob, 'probability that a read is an outlier (uniform phase)', 0.0, 0.999)
    walk_speed: float = param(_W.walk_speed, 'walking speed [m/s]', 1e-3, 10.0)
    turn_read_s: float = param(_W.turn_read_s, 'reads collected after a TURN to check the signal [s]', 0.0, 60.0)
    s_step: float = param(_W.s_step, 'step length s_step (§VI: 0.5 m) [m]', 1e-3, 10.0)
    s_r: float = param(_W.s_r, 'step error std s_r (§VI: 0.1 m) [m]', 0.0, 10.0)
    s_a_deg: float = param(math.degrees(_W.s_a), 'heading error std per step s_a (§VI: 11.5°) [deg]', 0.0, 180.0)
    step_model: str = param(_W.step_model, 'eq1: eqs. 1-2 (default); eq20: (s_step + r) along the heading',
                            choices=('eq1', 'eq20'))
    found_radius: float = param(_W.found_radius, 'the tag is found within this distance at the end of a MOVE [m]',
                                1e-3, 100.0)
    obstacles: str = param('none', 'none, or office: the obstacle variant (track_core.rfid.world.office_obstacles)',
                           choices=('none', 'office'))
    hop_dwell_s: float = param(0.0, 'frequency hopping: dwell per channel; 0 = one carrier (carrier_hz) [s]', 0.0, 60.0)
    hop_channels_mhz: list[float] = param([920.625 + 0.5 * j for j in range(8)], 'hopping carriers when hop_dwell_s > '
                                          '0 [MHz]')
    phase_step_rate: float = param(0.0, 'simulated lasting multipath phase steps per second; 0 = none [1/s]', 0.0, 1e3)
    phase_step_size: list[float] = param([0.8, 2.5], 'their size, uniform in [lo, hi], random sign [rad]')
    noise_dof: float = param(_W.noise_dof, 'heavy-tailed reads: Student-t read noise with this ν; 0 = Gaussian (the '
                             'paper)', 0.0, 1e6)
    noise_burst_s: float = param(_W.noise_burst_s, 'time over which the t noise keeps its scale (a fade) [s]',
                                 1e-6, 60.0)
    relock_reads: int = param(0, 'signal processing: agreeing reads that re-lock after a lasting phase step; 0 = never',
                              0, 1000)
    noise: str = param('fixed', 'signal processing: fixed (the paper), online (per-read noise from the data) or '
                       'robust (heavy-tailed, learnt)', choices=('fixed', 'online', 'robust'))
    time_scale: float = param(1.0, 'node seconds per second of the simulated action before answering; 0 = at once',
                              0.0, 1e3, live=True)
    tick: float = param(0.05, 'period of the timer that publishes due answers [node s]', 1e-3, 10.0, live=True)


@dataclass(frozen=True)
class _Answer:
    """What one command produced, published together when due (the step result last)."""

    stream: PointCloud2 | None
    pose: PoseStamped
    status: RfidUserStatusMsg
    step: RfidStepMsg


def world_params(p) -> WorldParams:
    """``WorldParams`` from the node parameters (ParameterError with one line when inconsistent)."""
    try:
        phase = phase_model(p)
        return WorldParams(
            phase=phase, start_distance=p.start_distance, beam_width=math.radians(p.beam_width_deg),
            max_range=p.max_range, back_lobe_range=p.back_lobe_range, read_rate=p.read_rate,
            outlier_prob=p.outlier_prob, walk_speed=p.walk_speed, turn_read_s=p.turn_read_s, s_step=p.s_step,
            s_r=p.s_r, s_a=math.radians(p.s_a_deg), found_radius=p.found_radius, step_model=p.step_model,
            obstacles=office_obstacles() if p.obstacles == 'office' else (), hop_dwell_s=p.hop_dwell_s,
            channels_hz=tuple(1e6 * f for f in p.hop_channels_mhz) if p.hop_dwell_s > 0 else (),
            phase_step_rate=p.phase_step_rate, phase_step_size=tuple(p.phase_step_size), noise_dof=p.noise_dof,
            noise_burst_s=p.noise_burst_s)
    except ValueError as exc:
        raise ParameterError(f'invalid world parameters: {exc}') from None


def pose_stamped(t: float, pose: np.ndarray, frame_id: str = FRAME_MAP) -> PoseStamped:
    msg = PoseStamped()
    msg.header.stamp, msg.header.frame_id = sec_to_stamp(t), frame_id
    msg.pose.position.x, msg.pose.position.y = float(pose[0]), float(pose[1])
    msg.pose.orientation.z, msg.pose.orientation.w = math.sin(0.5 * pose[2]), math.cos(0.5 * pose[2])
    return msg


class RfidReaderNode(TrackNode):
    DEFAULT_NAME = 'rfid_reader'
    Params = RfidReaderParams
    p: RfidReaderParams  # the declared parameters (base/params.py)

    def setup(self) -> None:
        p = self.p
        self.world = world_params(p)
        start = None
        if not p.random_start:
            s = np.asarray(p.start, dtype=float)
            if s.shape != (3,) or not np.all(np.isfinite(s)):
                raise ParameterError(f'parameter start={list(p.start)!r} is invalid: allowed 3 finite numbers '
                                     '[x m, y m, facing deg]')
            start = np.array([s[0], s[1], math.radians(s[2])])
        world_ss, _ = np.random.SeedSequence(p.seed).spawn(2)
        try:
            unwrap = UnwrapConfig.for_model(self.world.phase, relock_reads=p.relock_reads, noise=p.noise)
            self.reader = SimReader(self.world, np.random.default_rng(world_ss), start=start, unwrap=unwrap)
        except ValueError as exc:
            raise ParameterError(f'cannot start the search: {exc}') from None
        # The handheld reader is at the user: its frame (the node name, frame of /rfid/phase) on /tf_static.
        self.add_static_transforms(planar_transform(0.0, RFID_FRAME_USER, self.get_name(), 0.0, 0.0, 0.0))
        self.advertise_transforms()
        self.cache: AnswerCache[_Answer] = AnswerCache()  # one answer per seq (track_core.rfid.delivery)
        self.pub_phase = self.create_publisher(PointCloud2, RFID_PHASE, ESTIMATE_QOS)
        self.pub_pose = self.create_publisher(PoseStamped, RFID_USER_POSE, ESTIMATE_QOS)
        self.pub_status = self.create_publisher(RfidUserStatusMsg, RFID_USER_STATUS, ESTIMATE_QOS)
        self.pub_step = self.create_publisher(RfidStepMsg, RFID_STEP, ESTIMATE_QOS)
        self.sub_cmd = self.create_subscription(RfidCommandMsg, RFID_COMMAND, self._on_command, ESTIMATE_QOS)
        self.timer = self.create_timer(p.tick, self._tick)
        self.get_logger().info(f'user {self.reader.distance_to_tag():.2f} m from the tag at '
                               f'({self.reader.pose[0]:.2f}, {self.reader.pose[1]:.2f}) m, '
                               f'{self.reader.turns} rotation(s) to find the signal')

    def apply_params(self, changed: set[str]) -> None:
        if 'tick' in changed:  # time_scale is read at each command
            self.timer.timer_period_ns = round(self.p.tick * 1e9)

    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    # -- truth ----------------------------------------------------------------------------
    def _truth(self, t: float, seq: int) -> tuple[PoseStamped, RfidUserStatusMsg]:
        r = self.reader
        rec = RfidUserStatus(seq, r.steps, r.turns, float(r.distance), r.repeats, r.distance_to_tag(), r.found(),
                             float(r.pose[0]), float(r.pose[1]), float(r.pose[2]))
        return pose_stamped(t, r.pose), rec.to_msg(t)

    # -- commands -------------------------------------------------------------------------
    def _on_command(self, msg: RfidCommandMsg) -> None:
        try:
            cmd = read_command(msg)
        except RecordError as exc:
            self.cache.reject()
            self.refuse(RFID_COMMAND, f'command: {exc}')
            return
        verdict = self.cache.on_command(cmd.seq)
        if verdict is Verdict.REPLAY:  # the guidance has not seen the answer: send it again, nothing re-executed
            self.pub_step.publish(self.cache.answer.step)
        elif verdict is Verdict.STALE:
            self.get_logger().debug(f'{RFID_COMMAND}: ignored stale command #{cmd.seq} (last #{self.cache.seq})')
        elif verdict is Verdict.AHEAD:  # an absurd seq would make every real command stale: refused
            self.refuse(RFID_COMMAND, self.cache.ahead_problem(cmd.seq))
        elif verdict is Verdict.ENDED:
            self.refuse(RFID_COMMAND, f'ended: {cmd} after the search has ended')
        elif verdict is Verdict.EXECUTE:
            if self.cache.seq is None:  # the start pose (seq 0), once, before the first answer
                pose, status = self._truth(self._now(), 0)
                self._publish_pose(pose)
                self.pub_status.publish(status)
            self._execute(cmd)
            if self.p.time_scale == 0.0:
                self._tick()

    def _execute(self, cmd: Command) -> None:
        r = self.reader
        t0 = r.t
        out = r.execute(cmd)
        duration = r.t - t0
        due = self._now() + self.p.time_scale * duration
        res = out.result
        step = RfidStep.from_result(res, duration).to_msg(due)
        stream = None
        if cmd.kind is CommandKind.MOVE:
            s = out.stream
            t_start = s.t_start if s.t_start is not None else t0
            stream = RfidPhase.from_stream(due, s, t_start, self.world.phase.carrier_hz, r.pose).to_msg()
        pose, status = self._truth(due, cmd.seq)
        done = cmd.kind is CommandKind.DONE
        self.cache.store(cmd.seq, _Answer(stream, pose, status, step), due, done)
        if done:
            self.get_logger().info(f'search over ({cmd.reason or "done"}): {r.steps} steps, {r.turns} turns, '
                                   f'{r.distance:.1f} m walked, {r.distance_to_tag():.2f} m from the tag')

    def _tick(self) -> None:
        a = self.cache.take_due(self._now())
        if a is None:
            return
        if a.stream is not None:
            self.pub_phase.publish(a.stream)
        self._publish_pose(a.pose)
        self.pub_status.publish(a.status)
        self.pub_step.publish(a.step)

    def _publish_pose(self, pose: PoseStamped) -> None:
        """The true user pose, and the same as map → rfid_user on /tf (the user's body frame)."""
        self.send_transforms(pose_transform(pose.header, pose.pose, RFID_FRAME_USER))
        self.pub_pose.publish(pose)
