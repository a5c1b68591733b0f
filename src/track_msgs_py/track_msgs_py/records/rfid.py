"""Typed records of the RFID search links: command, step result, user truth, found event.

- ``RfidCommand``: ``/rfid/command``, guidance → reader (one ``protocol.Command``);
- ``RfidStep``: ``/rfid/step``, reader → guidance (one ``protocol.StepResult`` + ``duration``);
- ``RfidUserStatus``: ``/rfid/user/status``, the reader's truth (evaluation only);
- ``RfidFound``: ``/rfid/found``, the guidance's one event when the tag is reached;
- ``RfidPhase``: ``/rfid/phase``, the raw reads of one MOVE as a ``PointCloud2``: float32 ``x``,
  ``y``, ``z`` = where the reader was at each read (map, tag at the origin: the simulator's truth,
  on the segment the user walked; z = 0), then ``t`` (s since the step started), ``phase``
  (wrapped, rad), ``rssi`` (dBm), ``carrier_mhz``. Positions make the reads drawable where they
  were taken (coloured by phase, the wrapping is visible along the walk); nothing reads them back
  for processing.

Floats are written with the shortest repr, so dφ, turns and angles round-trip exactly. Field
order is the key order on the wire.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Self

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from sensor_msgs.msg import PointCloud2

from track_core.rfid.protocol import Command, CommandKind, StepResult
from track_core.rfid.signal import PhaseStream
from track_msgs_py.clouds import points_to_pointcloud2
from track_msgs_py.records import RecordError, StatusRecord, read_cloud
from track_msgs_py.stamps import stamp_to_sec
from track_msgs_py.topics import FRAME_MAP

KINDS = tuple(k.value for k in CommandKind)


def _kind(text: str) -> CommandKind:
    try:
        return CommandKind(text)
    except ValueError:
        raise RecordError(f'kind {text!r} is not one of {"|".join(KINDS)}') from None


@dataclass(frozen=True)
class RfidCommand(StatusRecord):
    """One command: ``seq`` ≥ 1, ``kind`` turn|move|done, ``angle`` rad (+ = left), ``angle_deg`` for reading."""

    KIND = 'rfid command'

    seq: int
    kind: str
    angle: float = 0.0
    angle_deg: float | None = field(default=None, metadata={'fmt': '{:.2f}'.format})
    repeat: bool = False
    reason: str = ''

    @classmethod
    def from_command(cls, cmd: Command) -> RfidCommand:
        return cls(cmd.seq, cmd.kind.value, float(cmd.angle), math.degrees(cmd.angle), cmd.repeat, cmd.reason)

    def command(self) -> Command:
        """The core's ``Command``; ``RecordError`` when the kind, seq or angle is unusable."""
        kind = _kind(self.kind)
        if self.seq < 1:
            raise RecordError(f'seq {self.seq} < 1')
        if not math.isfinite(self.angle):
            raise RecordError(f'non-finite angle={self.angle}')
        return Command(kind, self.angle, self.seq, self.repeat, self.reason)


def read_command(msg: DiagnosticArray) -> Command:
    """The ``Command`` of a ``/rfid/command`` message, or ``RecordError`` with one line."""
    if not msg.status:
        raise RecordError('no status')
    return RfidCommand.from_status(msg.status[0]).command()


@dataclass(frozen=True)
class RfidStep(StatusRecord):
    """One step result (the fields of ``StepResult``) and the simulated ``duration`` of the action [s].

    A value the core marks unknown with NaN (dφ and turn of an unusable step, the reader's dφ std
    with fixed noise) is an absent key on the wire, so no output carries a NaN; reading
    it back gives NaN again.
    """

    KIND = 'rfid step result'

    seq: int
    kind: str
    dphi: float | None
    turn: float | None
    n_reads: int
    n_outliers: int
    ok: bool
    reason: str
    found: bool
    duration: float
    dphi_std: float | None = None  # the reader's own dφ std; absent: unknown
    relocks: int = 0  # re-locks after lasting phase steps in this MOVE

    @classmethod
    def from_result(cls, res: StepResult, duration: float) -> RfidStep:
        return cls(res.seq, res.kind.value, _known(res.dphi), _known(res.turn), res.n_reads, res.n_outliers,
                   bool(res.ok), res.reason, bool(res.found), float(duration), _known(res.dphi_std), int(res.relocks))

    def result(self) -> StepResult:
        return StepResult(_kind(self.kind), self.seq, dphi=_nan(self.dphi), turn=_nan(self.turn), n_reads=self.n_reads,
                          n_outliers=self.n_outliers, ok=self.ok, reason=self.reason, found=self.found,
                          dphi_std=_nan(self.dphi_std), relocks=self.relocks)


def _known(v: float) -> float | None:
    return float(v) if math.isfinite(v) else None


def _nan(v: float | None) -> float:
    return math.nan if v is None else v


def read_step(msg: DiagnosticArray, pending: Command) -> tuple[StepResult, int | None]:
    """A ``/rfid/step`` message → (StepResult, its seq, or None when the seq is unreadable).

    Never raises: a message that does not hold a valid record becomes a result for ``pending``
    with ``ok`` False, NaN dφ and turn and the reason ``malformed step result: …``, so the core's
    bad-input rule (``protocol.step_result_problem``) warns and repeats the step. Its seq is the
    message's own when that one is readable (then the malformed answer still answers it).
    """
    try:
        if not msg.status:
            raise RecordError('no status')
        rec = RfidStep.from_status(msg.status[0])
        return rec.result(), rec.seq
    except RecordError as exc:
        seq = _seq(msg)
        bad = StepResult(pending.kind, pending.seq if seq is None else seq, dphi=math.nan, turn=math.nan,
                         ok=False, reason=f'malformed step result: {exc}')
        return bad, seq


@dataclass(frozen=True)
class _Seq(StatusRecord):
    KIND = 'rfid step result'
    seq: int


def _seq(msg: DiagnosticArray) -> int | None:
    try:
        return _Seq.from_status(msg.status[0]).seq if msg.status else None
    except RecordError:
        return None


@dataclass(frozen=True)
class RfidUserStatus(StatusRecord):
    """The user's truth after command ``seq`` (0: the start): counts, distances [m], pose (map, rad)."""

    KIND = 'rfid user status'

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


@dataclass(frozen=True)
class RfidFound(StatusRecord):
    """The found event: the step result's ``seq`` and the search's counters."""

    KIND = 'rfid found'

    seq: int
    moves: int
    turns: int
    updates: int
    resamples: int
    reinits: int


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
