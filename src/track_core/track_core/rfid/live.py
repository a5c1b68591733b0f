"""Live reader actions: the reads a real reader streams, cut into the MOVEs and TURNs the guidance commands.

A reader (LLRP) reports reads, never steps: the person holding it performs each command. When a
command arrives, its action opens on the local clock; the reads *taken* while it is open are its
stream. A MOVE stays open ``move_s`` (the time the user takes for one step, Section II) unless the
user confirms it earlier (``confirm``, a button in a UI); a TURN's check reads last ``turn_read_s``
after the turn was asked for, and the turn made is taken to be the one asked for (Section II: the
user performs the suggested rotation). DONE answers at once.

Clocks. A read carries the reader's time (LLRP µs timestamps) and reaches us later, by a latency
that varies and bunches reads (network, the client's thread, a busy machine). Windows are opened on
the local (arrival) clock and moved to the reader's clock by the offset ô = max over reads of
(reader time − arrival time): the arrival is the read's time plus a latency ≥ 0, so the read that
came fastest bounds the offset best. A read belongs to the action whose window holds its *reader*
time. The answer is due once a read taken after the window's end has arrived (a reader reports its
reads in the order it takes them, over one TCP stream: every read of the window is in), or, when no
such read comes (the tag is no longer read), ``latency_s`` after the window closed on the local
clock. So the answer does not depend on how fast this process runs: when it is starved (a busy
machine), the reads wait in the socket with their reader times and the window is still cut by those.
A step back of the reader's clock by more than ``CLOCK_RESET_S`` (a reader that restarted) starts ô
afresh. The stream's ``t_start``/``t_end`` (the button presses of ``signal.process_move``) are the
window's ends on the reader's clock. Reads taken while no action is open are dropped and counted
(``idle_reads``): nobody is moving, they belong to no step.

The MOVE's dφ comes from one ``PhaseProcessor`` (the noise it learns carries over between MOVEs), so
a live walk and its replay (``log.LogReplay``) process reads the same way.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from track_core.rfid.protocol import Command, CommandKind, StepResult
from track_core.rfid.signal import PhaseProcessor, PhaseStream


@dataclass(frozen=True)
class LiveAnswer:
    """One performed command: its result, its reads (``stream``, reader clock) and its length (s)."""

    command: Command
    result: StepResult
    stream: PhaseStream
    duration: float


CLOCK_RESET_S = 5.0   # a reader clock that steps back this far restarted: the offset is learnt again


@dataclass
class _Open:
    command: Command
    t0: float                      # arrival clock
    t1: float                      # when it closes (arrival clock)
    rows: list = field(default_factory=list)   # (reader t, phase, rssi, carrier Hz) arrays


class LiveActions:
    """Commands in, reads in, answers out once their window has closed and ``latency_s`` passed (module doc)."""

    def __init__(self, processor: PhaseProcessor, move_s: float, turn_read_s: float, latency_s: float = 0.2) -> None:
        if not (move_s > 0.0 and turn_read_s >= 0.0 and latency_s >= 0.0):
            raise ValueError(f'move_s must be > 0, turn_read_s and latency_s >= 0, got {move_s}, {turn_read_s}, '
                             f'{latency_s}')
        self.processor = processor
        self.move_s, self.turn_read_s, self.latency_s = move_s, turn_read_s, latency_s
        self.current: _Open | None = None
        self.offset = -math.inf      # ô: reader clock − arrival clock
        self.latest = -math.inf      # reader time of the newest read
        self.idle_reads = 0
        self.steps = self.turns = 0

    def start(self, cmd: Command, now: float) -> None:
        """Open ``cmd``'s action at arrival time ``now`` (the previous one must have been answered)."""
        if self.current is not None:
            raise RuntimeError(f'{cmd} while {self.current.command} is still open')
        length = {CommandKind.MOVE: self.move_s, CommandKind.TURN: self.turn_read_s}.get(cmd.kind, 0.0)
        self.current = _Open(cmd, now, now + length)

    def confirm(self, now: float) -> bool:
        """The user confirms the open MOVE at ``now`` (it closes then); False when no MOVE is open."""
        if self.current is None or self.current.command.kind is not CommandKind.MOVE:
            return False
        self.current.t1 = min(self.current.t1, now)
        return True

    def add(self, arrival: np.ndarray, t: np.ndarray, phase: np.ndarray, rssi: np.ndarray,
            carrier_hz: np.ndarray) -> None:
        """Reads of the tag (arrival and reader times, s); kept while an action is open, else counted idle."""
        arrival, t = np.asarray(arrival, dtype=float), np.asarray(t, dtype=float)
        if not t.size:
            return
        lead = float(np.max(t - arrival))
        reset = lead < self.offset - CLOCK_RESET_S       # the reader restarted: its clock is learnt again
        self.offset = lead if reset else max(self.offset, lead)
        self.latest = float(np.max(t)) if reset else max(self.latest, float(np.max(t)))
        c = self.current
        keep = np.zeros(t.size, bool) if c is None else t >= c.t0 + self.offset
        self.idle_reads += int(t.size - keep.sum())
        if keep.any():
            c.rows.append(tuple(np.asarray(v, dtype=float)[keep] for v in (t, phase, rssi, carrier_hz)))

    def take_due(self, now: float) -> LiveAnswer | None:
        """The open action's answer once a read after its window has come, or ``now`` (arrival clock) is
        ``latency_s`` past the window's end (module doc)."""
        c = self.current
        if c is None or now < c.t1:
            return None
        if now < c.t1 + (self.latency_s if c.t1 > c.t0 else 0.0) and not self.latest > c.t1 + self.offset:
            return None
        self.current = None
        t0, t1 = c.t0 + self.offset, c.t1 + self.offset
        t, phase, rssi, carrier = (np.concatenate([r[j] for r in c.rows]) if c.rows else np.empty(0)
                                   for j in range(4))
        inside = (t >= t0) & (t <= t1)
        self.idle_reads += int(t.size - inside.sum())           # taken after the window: nobody asked
        order = np.argsort(t[inside], kind='stable')
        t, phase, rssi, carrier = (v[inside][order] for v in (t, phase, rssi, carrier))
        stream = PhaseStream(t, phase, rssi, t0 if math.isfinite(t0) else None, t1 if math.isfinite(t1) else None,
                             carrier)
        cmd = c.command
        if cmd.kind is CommandKind.MOVE:
            self.steps += 1
            e = self.processor.process(stream)
            res = StepResult(CommandKind.MOVE, cmd.seq, dphi=e.dphi, n_reads=e.n_reads, n_outliers=e.n_outliers,
                             ok=e.ok, reason=e.reason, dphi_std=e.dphi_std, relocks=e.relocks)
        elif cmd.kind is CommandKind.TURN:
            self.turns += 1
            n = len(stream)
            res = StepResult(CommandKind.TURN, cmd.seq, turn=cmd.angle, n_reads=n, ok=n > 0,
                             reason='' if n else 'tag not read this way')
        else:
            res = StepResult(cmd.kind, cmd.seq)
        return LiveAnswer(cmd, res, stream, c.t1 - c.t0)

    @property
    def busy(self) -> bool:
        return self.current is not None


def channel_carriers(channels: np.ndarray, table_hz: tuple[float, ...]) -> np.ndarray:
    """LLRP ChannelIndex (1-based) → carrier (Hz) by the reader's hop table; NaN for an index outside it."""
    ch = np.asarray(channels, dtype=int)
    table = np.asarray(table_hz, dtype=float)
    ok = (ch >= 1) & (ch <= table.size)
    out = np.full(ch.shape, math.nan)
    out[ok] = table[ch[ok] - 1]
    return out
