"""Typed records of the RFID search links ⇄ their ``track_msgs`` messages, and the phase cloud.

- ``RfidCommand`` (``/rfid/command``, guidance → reader): one ``protocol.Command``: ``seq``,
  ``kind`` ⇄ the ``TURN``/``MOVE``/``DONE`` constants, ``angle`` (rad), ``angle_deg`` (written from
  ``angle``; read: checked finite, not used), ``repeat``, ``reason``.
- ``RfidStep`` (``/rfid/step``, reader → guidance): one ``protocol.StepResult`` + ``duration`` [s];
  the core's NaN (unknown ``dphi``, ``turn``, ``dphi_std``) ⇄ ``None`` here ⇄ ``<field>_known``
  false and 0 on the wire, so no output carries a NaN.
- ``RfidUserStatus`` (``/rfid/user/status``): the reader's truth (evaluation only), frame ``map``.
- ``RfidFound`` (``/rfid/found``): the guidance's one event when the tag is reached: the result's
  ``seq`` and the search's counters.
- ``RfidPhase`` (``/rfid/phase``, PointCloud2): the raw reads of one MOVE: float32 ``x``, ``y``,
  ``z`` = where the reader was at each read (map, tag at the origin: the simulator's truth, for
  drawing only; z = 0), then ``t`` (s since the step started), ``phase`` (wrapped, rad), ``rssi``
  (dBm), ``carrier_mhz``.

``to_msg(t)`` stamps the header with ``t``; ``from_msg`` reads the fields back exactly (float64 on
the wire) and raises ``RecordError`` with one line for input no sender of ours writes: an unknown
kind value, a seq 0, a non-finite angle, duration or known ``dphi_std``. A NaN ``dphi`` or ``turn``
passes, so that the core's bad-input rule (``protocol.step_result_problem``) words the warning.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Self

import numpy as np
from sensor_msgs.msg import PointCloud2

from track_core.rfid.protocol import Command, CommandKind, StepResult
from track_core.rfid.signal import PhaseStream
from track_msgs import msg as tm
from track_msgs_py.clouds import points_to_pointcloud2
from track_msgs_py.records import RecordError, finite_value, read_cloud
from track_msgs_py.stamps import stamp_to_sec, stamped_header
from track_msgs_py.topics import FRAME_MAP

#: The wire value of each kind (the constants of RfidCommand and RfidStep, equal in both).
KIND_VALUES = {CommandKind.TURN: tm.RfidCommand.TURN, CommandKind.MOVE: tm.RfidCommand.MOVE,
               CommandKind.DONE: tm.RfidCommand.DONE}
_KINDS = {v: k for k, v in KIND_VALUES.items()}
_KIND_WORDS = ', '.join(f'{v} ({k.value})' for k, v in KIND_VALUES.items())


def _kind(record: str, value: int) -> CommandKind:
    try:
        return _KINDS[value]
    except KeyError:
        raise RecordError(f'{record}: kind {value} is not one of {_KIND_WORDS}') from None


@dataclass(frozen=True)
class RfidCommand:
    """One command: ``seq`` ≥ 1, ``kind``, ``angle`` rad (+ = left); ``angle_deg`` is written from it."""

    seq: int
    kind: CommandKind
    angle: float = 0.0
    repeat: bool = False
    reason: str = ''

    @classmethod
    def from_command(cls, cmd: Command) -> RfidCommand:
        return cls(cmd.seq, cmd.kind, float(cmd.angle), cmd.repeat, cmd.reason)

    def command(self) -> Command:
        return Command(self.kind, self.angle, self.seq, self.repeat, self.reason)

    def to_msg(self, t: float) -> tm.RfidCommand:
        return tm.RfidCommand(header=stamped_header(t, ''), seq=self.seq, kind=KIND_VALUES[self.kind],
                              angle=self.angle, angle_deg=math.degrees(self.angle), repeat=self.repeat,
                              reason=self.reason)

    @classmethod
    def from_msg(cls, msg: tm.RfidCommand) -> Self:
        """``RecordError`` with one line when the kind, seq or an angle is unusable."""
        kind = _kind('rfid command', msg.kind)
        if msg.seq < 1:
            raise RecordError(f'rfid command: seq {msg.seq} < 1')
        finite_value('rfid command', 'angle_deg', msg.angle_deg)
        return cls(msg.seq, kind, finite_value('rfid command', 'angle', msg.angle), msg.repeat, msg.reason)


def read_command(msg: tm.RfidCommand) -> Command:
    """The ``Command`` of a ``/rfid/command`` message, or ``RecordError`` with one line."""
    return RfidCommand.from_msg(msg).command()


@dataclass(frozen=True)
class RfidStep:
    """One step result (the fields of ``StepResult``) and the simulated ``duration`` of the action [s].

    ``None``: a value the core marks unknown with NaN (dφ and turn of an unusable step, the reader's
    dφ std with fixed noise); reading it back gives NaN again.
    """

    seq: int
    kind: CommandKind
    dphi: float | None
    turn: float | None
    n_reads: int
    n_outliers: int
    ok: bool
    reason: str
    found: bool
    duration: float
    dphi_std: float | None = None  # the reader's own dφ std; None: unknown
    relocks: int = 0  # re-locks after lasting phase steps in this MOVE

    @classmethod
    def from_result(cls, res: StepResult, duration: float) -> RfidStep:
        return cls(res.seq, res.kind, _known(res.dphi), _known(res.turn), res.n_reads, res.n_outliers,
                   bool(res.ok), res.reason, bool(res.found), float(duration), _known(res.dphi_std), int(res.relocks))

    def result(self) -> StepResult:
        return StepResult(self.kind, self.seq, dphi=_nan(self.dphi), turn=_nan(self.turn), n_reads=self.n_reads,
                          n_outliers=self.n_outliers, ok=self.ok, reason=self.reason, found=self.found,
                          dphi_std=_nan(self.dphi_std), relocks=self.relocks)

    def to_msg(self, t: float) -> tm.RfidStep:
        return tm.RfidStep(header=stamped_header(t, ''), seq=self.seq, kind=KIND_VALUES[self.kind],
                           dphi=_or0(self.dphi), dphi_known=self.dphi is not None, turn=_or0(self.turn),
                           turn_known=self.turn is not None, n_reads=self.n_reads, n_outliers=self.n_outliers,
                           ok=self.ok, reason=self.reason, found=self.found, duration=self.duration,
                           dphi_std=_or0(self.dphi_std), dphi_std_known=self.dphi_std is not None,
                           relocks=self.relocks)

    @classmethod
    def from_msg(cls, msg: tm.RfidStep) -> Self:
        """``RecordError`` with one line for an unknown kind, a non-finite duration or known dφ std ≤ 0."""
        kind = _kind('rfid step result', msg.kind)
        duration = finite_value('rfid step result', 'duration', msg.duration)
        dphi_std = None
        if msg.dphi_std_known:
            dphi_std = finite_value('rfid step result', 'dphi_std', msg.dphi_std)
            if dphi_std <= 0.0:
                raise RecordError(f'rfid step result: dphi_std={dphi_std} is not > 0')
        return cls(msg.seq, kind, msg.dphi if msg.dphi_known else None, msg.turn if msg.turn_known else None,
                   msg.n_reads, msg.n_outliers, msg.ok, msg.reason, msg.found, duration, dphi_std, msg.relocks)


def _known(v: float) -> float | None:
    return float(v) if math.isfinite(v) else None


def _nan(v: float | None) -> float:
    return math.nan if v is None else v


def _or0(v: float | None) -> float:
    return 0.0 if v is None else v


def read_step(msg: tm.RfidStep, pending: Command) -> tuple[StepResult, int]:
    """A ``/rfid/step`` message → (StepResult, its seq). Never raises.

    A message that does not hold a valid record becomes a result for its own seq with ``pending``'s
    kind, ``ok`` False, NaN dφ and turn and the reason ``malformed step result: …``, so the core's
    bad-input rule (``protocol.step_result_problem``) warns and repeats the step (a malformed answer
    with the pending seq still answers it).
    """
    try:
        rec = RfidStep.from_msg(msg)
        return rec.result(), rec.seq
    except RecordError as exc:
        bad = StepResult(pending.kind, msg.seq, dphi=math.nan, turn=math.nan, ok=False,
                         reason=f'malformed step result: {exc}')
        return bad, msg.seq


@dataclass(frozen=True)
class RfidUserStatus:
    """The user's truth after command ``seq`` (0: the start): counts, distances [m], pose (map, rad)."""

    seq: int
    steps: int
    turns: int
    distance_m: float
    repeats: int
    distance_to_tag_m: float
    found: bool
    x: float
    y: float
    heading: float

    def to_msg(self, t: float) -> tm.RfidUserStatus:
        return tm.RfidUserStatus(header=stamped_header(t, FRAME_MAP), seq=self.seq, steps=self.steps,
                                 turns=self.turns, distance_m=self.distance_m, repeats=self.repeats,
                                 distance_to_tag_m=self.distance_to_tag_m, found=self.found, x=self.x, y=self.y,
                                 heading=self.heading)

    @classmethod
    def from_msg(cls, msg: tm.RfidUserStatus) -> Self:
        return cls(msg.seq, msg.steps, msg.turns, msg.distance_m, msg.repeats, msg.distance_to_tag_m, msg.found,
                   msg.x, msg.y, msg.heading)


@dataclass(frozen=True)
class RfidFound:
    """The found event: the step result's ``seq`` and the search's counters."""

    seq: int
    moves: int
    turns: int
    updates: int
    resamples: int
    reinits: int

    def to_msg(self, t: float) -> tm.RfidFound:
        return tm.RfidFound(header=stamped_header(t, ''), seq=self.seq, moves=self.moves, turns=self.turns,
                            updates=self.updates, resamples=self.resamples, reinits=self.reinits)

    @classmethod
    def from_msg(cls, msg: tm.RfidFound) -> Self:
        return cls(msg.seq, msg.moves, msg.turns, msg.updates, msg.resamples, msg.reinits)


#: The table fields of ``/rfid/phase`` after x, y, z.
PHASE_FIELDS = ('t', 'phase', 'rssi', 'carrier_mhz')


@dataclass(frozen=True, eq=False)
class RfidPhase:
    """The reads of one MOVE, stamped ``stamp`` (the step result's stamp): per read ``t`` [s since the step
    started], ``phase`` [rad, wrapped], ``rssi`` [dBm], ``carrier_mhz`` and ``xy`` (n, 2), where it was taken."""

    stamp: float
    t: np.ndarray
    phase: np.ndarray
    rssi: np.ndarray
    carrier_mhz: np.ndarray
    xy: np.ndarray
    frame_id: str = FRAME_MAP

    @classmethod
    def from_stream(cls, stamp: float, stream: PhaseStream, t_start: float, carrier_hz: float,
                    at: np.ndarray) -> RfidPhase:
        """A core ``PhaseStream``: times relative to ``t_start``, reads without a carrier on ``carrier_hz``,
        reads without a position (``stream.xy`` None) at ``at`` (x, y)."""
        n = len(stream)
        carrier = np.full(n, carrier_hz) if stream.carrier_hz is None else stream.carrier_hz
        xy = np.tile(np.asarray(at, dtype=float)[:2], (n, 1)) if stream.xy is None else stream.xy
        return cls(stamp, stream.t - t_start, stream.phase, stream.rssi, carrier / 1e6, xy)

    def to_msg(self) -> PointCloud2:
        return points_to_pointcloud2(self.stamp, self.frame_id, self.xy,
                                     {k: getattr(self, k) for k in PHASE_FIELDS})

    @classmethod
    def from_msg(cls, msg: PointCloud2) -> Self:
        """Needs every field of ``PHASE_FIELDS`` and x, y; else ``RecordError`` with one line."""
        table = read_cloud('rfid phase', msg, ('x', 'y', *PHASE_FIELDS))
        return cls(stamp_to_sec(msg.header.stamp), *(table[k] for k in PHASE_FIELDS),
                   np.stack([table['x'], table['y']], axis=1), msg.header.frame_id)
