"""Reader logs: a recorded walk (the tag reads plus the user's MOVE/TURN events) as one CSV file.

A real reader reports reads, not steps: the button presses come from elsewhere. One file holds both,
in time order, processed offline (``track-experiment rfid-reader --set file=LOG.csv``), replayed on
topics (``rfid_log_reader``) or written by our simulator (``write_log``, ``write_example``).

Layout (UTF-8, a BOM tolerated; ``,``-separated; a header row naming the columns in any order,
extra columns ignored):
- leading ``# key: value`` lines (an unknown key refused) or ``# text``: ``format``
  (``track-rfid-log 1``), ``convention`` (``llrp`` default: phase rises with distance; ``paper``:
  eq. 3), ``wrap`` (``2pi`` default, or ``pi``), ``carrier_mhz`` (dφ's reference; default the first
  read's), ``epc``, ``channels_mhz`` (the hop table for the 1-based channel indices);
- columns ``time`` (s, never decreasing), ``epc``, ``antenna``, ``phase`` (rad, in [0, P]), ``rssi``
  (dBm), ``event``, ``value``, and ``channel`` (LLRP ChannelIndex) or ``carrier_mhz``; optional
  truth ``x``, ``y`` (m), ``heading`` (rad), tag at the origin;
- a read row has an empty ``event`` (``epc`` hex in 16-bit words, ``antenna`` ≥ 1);
- an event row: ``move_start`` (``value`` the commanded step in m, or empty), ``move_end``, or
  ``turn`` (``value`` degrees, + = left); its read columns empty.
Reads of other EPCs are dropped and counted (``ReaderLog.other_reads``); several tags and no ``epc``
is refused. A bad row (missing column, bad number, malformed EPC, time backwards, an event out of
order) refuses the file with one line naming line and column (``LogError``, a ``ValueError``).
"""

from __future__ import annotations

import csv
import math
import re
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from track_core.rfid.phase import CARRIER_RANGE_HZ, CONVENTIONS, PhaseModel
from track_core.rfid.protocol import Command, CommandKind, StepResult
from track_core.rfid.signal import PhaseProcessor, PhaseStream, UnwrapConfig
from track_core.rfid.world import ReaderOutput, SimReader, WorldParams

FORMAT = 'track-rfid-log 1'
EVENTS = ('move_start', 'move_end', 'turn')
REQUIRED = ('time', 'epc', 'antenna', 'phase', 'rssi', 'event', 'value')
TRUTH = ('x', 'y', 'heading')
COLUMNS = ('time', 'epc', 'antenna', 'channel', 'carrier_mhz', 'phase', 'rssi', 'event', 'value', *TRUTH)
META_KEYS = ('format', 'convention', 'wrap', 'carrier_mhz', 'epc', 'channels_mhz')
WRAPS = {'pi': math.pi, '2pi': 2.0 * math.pi}
RSSI_RANGE = (-150.0, 50.0)
SIM_EPC = 'E20000000000000000005A01'   # the simulator's tag (a made-up EPC-96)
_EPC = re.compile(r'^(?:[0-9A-Fa-f]{4}){1,16}$')
_META = re.compile(r'^#\s*([a-z_]+)\s*:\s*(.*)$')


class LogError(ValueError):
    """A refused log: one line naming the file, the line and the column."""


@dataclass(frozen=True)
class LogMeta:
    """The reader's conventions, from the file's ``# key: value`` lines (module doc)."""

    convention: str = 'llrp'
    wrap: str = '2pi'
    carrier_mhz: float | None = None
    epc: str | None = None
    channels_mhz: tuple[float, ...] = ()

    def phase_model(self, carrier_hz: float, s_theta: float = 0.015) -> PhaseModel:
        """The ``PhaseModel`` of this reader at reference carrier ``carrier_hz``."""
        return PhaseModel.with_wrap(self.wrap, carrier_hz=carrier_hz, s_theta=s_theta, convention=self.convention)


@dataclass(frozen=True)
class LogAction:
    """One MOVE or TURN of the log: its reads (``stream``, t_start/t_end = the events' times) and ``value``
    (MOVE: commanded step length m, NaN unknown; TURN: the turn made, rad, + = left). ``start``/``pose``:
    the truth (x, y, heading) at its start and end when the log has it, else None."""

    kind: CommandKind
    seq: int
    value: float
    stream: PhaseStream
    line: int = 0
    antenna: np.ndarray = field(default_factory=lambda: np.empty(0, int))
    start: np.ndarray | None = None
    pose: np.ndarray | None = None

    @property
    def duration(self) -> float:
        return float(self.stream.t_end - self.stream.t_start)

    def truth_dphi(self, k: float) -> float:
        """Eq. 6's geometric dφ = k(|E| − |S|) of a MOVE from the truth (NaN: none in the log)."""
        if self.kind is not CommandKind.MOVE or self.start is None or self.pose is None:
            return math.nan
        return k * (math.hypot(*self.pose[:2]) - math.hypot(*self.start[:2]))


@dataclass(frozen=True)
class ReaderLog:
    """A read log: the tag's EPC, its MOVEs and TURNs in order, and what was dropped."""

    meta: LogMeta
    epc: str
    actions: tuple[LogAction, ...]
    carrier_hz: float          # the reference carrier (metadata, else the first read's)
    n_reads: int               # reads of the tag
    other_reads: int = 0       # reads of other EPCs, dropped
    has_truth: bool = False
    source: str = ''

    @property
    def moves(self) -> list[LogAction]:
        return [a for a in self.actions if a.kind is CommandKind.MOVE]

    def phase_model(self, s_theta: float = 0.015) -> PhaseModel:
        return self.meta.phase_model(self.carrier_hz, s_theta)

    def describe(self) -> str:
        turns = len(self.actions) - len(self.moves)
        other = f', {self.other_reads} reads of other tags dropped' if self.other_reads else ''
        return (f'{self.source or "log"}: tag {self.epc}, {self.n_reads} reads, {len(self.moves)} MOVEs, {turns} '
                f'TURNs, {self.meta.convention} sign, wrap {self.meta.wrap}{other}'
                + (', with truth' if self.has_truth else ''))


def _num(where: str, col: str, text: str, lo: float = -math.inf, hi: float = math.inf) -> float:
    try:
        v = float(text)
    except ValueError:
        raise LogError(f'{where}, column {col}: {text!r} is not a number') from None
    if not math.isfinite(v):
        raise LogError(f'{where}, column {col}: {text!r} is not a finite number')
    if not lo <= v <= hi:
        raise LogError(f'{where}, column {col}: {v:g} is outside [{lo:g}, {hi:g}]')
    return v


def _int(where: str, col: str, text: str) -> int:
    if not text.strip().isdigit() or int(text) < 1:
        raise LogError(f'{where}, column {col}: {text!r} is not an integer >= 1')
    return int(text)


def _meta(lines: list[tuple[int, str]], name: str) -> LogMeta:
    kw: dict = {}
    for ln, text in lines:
        m = _META.match(text)
        if m is None:
            continue
        key, value, where = m.group(1), m.group(2).strip(), f'{name}: line {ln}'
        if key not in META_KEYS:
            raise LogError(f'{where}: unknown metadata key {key!r}; known: {", ".join(META_KEYS)}')
        if key == 'format' and value != FORMAT:
            raise LogError(f'{where}: format {value!r} is not {FORMAT!r}')
        if key == 'convention' and value not in CONVENTIONS:
            raise LogError(f'{where}: convention {value!r} is not one of {", ".join(CONVENTIONS)}')
        if key == 'wrap' and value not in WRAPS:
            raise LogError(f'{where}: wrap {value!r} is not one of {", ".join(WRAPS)}')
        if key == 'epc' and not _EPC.match(value):
            raise LogError(f'{where}: epc {value!r} is not an EPC (hex digits, a multiple of 4)')
        lo, hi = (f / 1e6 for f in CARRIER_RANGE_HZ)
        if key == 'carrier_mhz':
            kw[key] = _num(where, key, value, lo, hi)
        elif key == 'channels_mhz':
            kw[key] = tuple(_num(where, key, v, lo, hi) for v in value.split())
        elif key == 'epc':
            kw[key] = value.upper()
        elif key != 'format':
            kw[key] = value
    return LogMeta(**kw)


@dataclass
class _Open:
    """An action being read: its first line, kind, value, start time, reads and truth at its start."""

    kind: CommandKind
    line: int
    value: float
    t0: float
    start: np.ndarray | None
    rows: list = field(default_factory=list)


def read_log(path: str | Path, epc: str | None = None) -> ReaderLog:
    """Read and check a log (module doc); ``epc`` (or the file's ``# epc:``) selects the tag."""
    path = Path(path)
    name = path.name
    try:
        with path.open(newline='', encoding='utf-8-sig') as f:
            text = f.read()
    except UnicodeDecodeError as exc:
        raise LogError(f'{name}: not UTF-8 text ({exc.reason} at byte {exc.start})') from None
    lines = text.splitlines()
    n_comment = next((i for i, s in enumerate(lines) if not s.startswith('#')), len(lines))
    meta = _meta([(i + 1, s) for i, s in enumerate(lines[:n_comment])], name)
    if epc is not None:
        if not _EPC.match(epc):
            raise LogError(f'{name}: epc {epc!r} is not an EPC (hex digits, a multiple of 4)')
        meta = replace(meta, epc=epc.upper())
    rows = csv.reader(lines[n_comment:])
    hline = n_comment + 1
    header = [h.strip() for h in next(rows, [])]
    col = _columns(name, hline, header)
    truth = all(c in col for c in TRUTH)
    reads: list[tuple] = []        # (t, epc, antenna, carrier_mhz, phase, rssi, xy, line)
    events: list[tuple] = []       # (line, kind, value, t, pose)
    t_prev, l_prev = -math.inf, 0
    for i, row in enumerate(rows):
        ln = hline + 1 + i
        if not row or all(not c.strip() for c in row):
            continue
        where = f'{name}: line {ln}'
        if len(row) != len(header):
            raise LogError(f'{where}: {len(row)} fields, the header (line {hline}) has {len(header)}')
        cells = {c: row[col[c]].strip() if c in col else '' for c in COLUMNS}
        t = _num(where, 'time', cells['time'])
        if t < t_prev:
            raise LogError(f'{where}, column time: {t:g} s is before the previous row\'s {t_prev:g} s '
                           f'(line {l_prev}): times must not go backwards')
        t_prev, l_prev = t, ln
        pose = _pose(where, cells) if truth and cells['x'] else None
        if cells['event']:
            events.append((ln, cells['event'], _event_value(where, cells['event'], cells['value']), t, pose))
        else:
            reads.append(_read(where, cells, meta, t, pose, ln))
    return _assemble(path, meta, _spans(name, events, t_prev), reads, truth)


def _columns(name: str, hline: int, header: list[str]) -> dict:
    """Column name → index of the columns present, or the refusal of a header missing a column."""
    missing = [c for c in REQUIRED if c not in header]
    if not header or missing:
        raise LogError(f'{name}: line {hline}: missing column{"s" * (len(missing) > 1)} '
                       f'{", ".join(missing or REQUIRED)} (need {", ".join(REQUIRED)}, and channel or carrier_mhz)')
    if 'channel' not in header and 'carrier_mhz' not in header:
        raise LogError(f'{name}: line {hline}: missing column channel or carrier_mhz')
    return {c: header.index(c) for c in COLUMNS if c in header}


def _pose(where: str, cells: dict) -> np.ndarray:
    head = _num(where, 'heading', cells['heading']) if cells['heading'] else math.nan
    return np.array([_num(where, 'x', cells['x']), _num(where, 'y', cells['y']), head])


def _event_value(where: str, ev: str, v: str) -> float:
    """An event row's ``value``: a TURN's angle (rad), a MOVE's commanded length (m; NaN: not given)."""
    if ev not in EVENTS:
        raise LogError(f'{where}, column event: {ev!r} is not one of {", ".join(EVENTS)} (empty: a read)')
    if ev == 'turn':
        return math.radians(_num(where, 'value', v, -360.0, 360.0))
    if ev == 'move_start' and v:
        return _num(where, 'value', v, 0.0, 100.0)
    return math.nan


def _read(where: str, cells: dict, meta: LogMeta, t: float, pose: np.ndarray | None, ln: int) -> tuple:
    """One read row, checked: (t, epc, antenna, carrier_mhz, phase, rssi, xy, line)."""
    tag = cells['epc']
    if not _EPC.match(tag):
        raise LogError(f'{where}, column epc: {tag!r} is not an EPC (hex digits, a multiple of 4)')
    ant = _int(where, 'antenna', cells['antenna'])
    phase = _num(where, 'phase', cells['phase'], 0.0, WRAPS[meta.wrap])
    rssi = _num(where, 'rssi', cells['rssi'], *RSSI_RANGE)
    lo_mhz, hi_mhz = (f / 1e6 for f in CARRIER_RANGE_HZ)
    if cells['carrier_mhz']:
        mhz = _num(where, 'carrier_mhz', cells['carrier_mhz'], lo_mhz, hi_mhz)
    elif cells['channel']:
        ch = _int(where, 'channel', cells['channel'])
        if ch > len(meta.channels_mhz):
            raise LogError(f'{where}, column channel: channel {ch} is not in the hop table (# channels_mhz: has '
                           f'{len(meta.channels_mhz)} carriers); give carrier_mhz or the table')
        mhz = meta.channels_mhz[ch - 1]
    else:
        raise LogError(f'{where}, column carrier_mhz: empty, and no channel either')
    xy = (pose[0], pose[1]) if pose is not None else None
    return (t, tag.upper(), ant, mhz, phase, rssi, xy, ln)


def _assemble(path: Path, meta: LogMeta, spans: list, reads: list[tuple], truth: bool) -> ReaderLog:
    """The tag's reads (``meta.epc``, else the only tag read) grouped into the log's actions."""
    name = path.name
    tags = sorted({r[1] for r in reads})
    if meta.epc is None:
        if len(tags) > 1:
            raise LogError(f'{name}: reads of {len(tags)} tags ({", ".join(tags[:4])}{", ..." * (len(tags) > 4)}): '
                           'choose one with epc')
        if not tags:
            raise LogError(f'{name}: no reads')
        meta = replace(meta, epc=tags[0])
    mine = [r for r in reads if r[1] == meta.epc]
    if not mine:
        raise LogError(f'{name}: no read of the tag {meta.epc} (the log has {", ".join(tags[:4]) or "no reads"})')
    carrier_mhz = meta.carrier_mhz if meta.carrier_mhz is not None else mine[0][3]
    actions = _actions(spans, mine, truth)
    return ReaderLog(meta, meta.epc, actions, carrier_mhz * 1e6, len(mine), len(reads) - len(mine),
                     truth, str(path))


def _spans(name: str, events: list[tuple], t_last: float) -> list[_Open]:
    """Pair the events into MOVEs and TURNs (``rows`` = [t_end, pose at the end]); refuse them out of order."""
    spans: list[_Open] = []
    cur: _Open | None = None
    for ln, ev, value, t, pose in events:
        if ev == 'move_end':
            if cur is None or cur.kind is not CommandKind.MOVE:
                raise LogError(f'{name}: line {ln}, column event: move_end without a move_start before it')
            spans.append(replace(cur, rows=[t, pose]))
            cur = None
            continue
        if cur is not None and cur.kind is CommandKind.MOVE:
            raise LogError(f'{name}: line {ln}, column event: {ev} inside the MOVE started at line {cur.line} '
                           '(move_end first)')
        if cur is not None:                        # a TURN ends at the next event
            spans.append(replace(cur, rows=[t, cur.start]))
        kind = CommandKind.MOVE if ev == 'move_start' else CommandKind.TURN
        cur = _Open(kind, ln, value, t, pose)      # a TURN's row holds the pose after it
    if cur is not None and cur.kind is CommandKind.MOVE:
        raise LogError(f'{name}: line {cur.line}: the MOVE started here has no move_end')
    if cur is not None:
        spans.append(replace(cur, rows=[max(cur.t0, t_last), cur.start]))
    return spans


def _actions(spans: list[_Open], reads: list[tuple], truth: bool) -> tuple[LogAction, ...]:
    """Each MOVE or TURN with its reads: those between its start and end times."""
    t_all = np.array([r[0] for r in reads])
    out = []
    for seq, sp in enumerate(spans, start=1):
        t_end, end_pose = sp.rows
        a, b = int(np.searchsorted(t_all, sp.t0, 'left')), int(np.searchsorted(t_all, t_end, 'right'))
        sel = reads[a:b]
        xy = np.array([r[6] for r in sel], dtype=float).reshape(-1, 2) \
            if truth and sel and all(r[6] is not None for r in sel) else None
        stream = PhaseStream(np.array([r[0] for r in sel]), np.array([r[4] for r in sel]),
                             np.array([r[5] for r in sel]), sp.t0, t_end,
                             np.array([r[3] * 1e6 for r in sel]), xy)
        out.append(LogAction(sp.kind, seq, sp.value, stream, sp.line, np.array([r[2] for r in sel], dtype=int),
                             sp.start, end_pose))
    return tuple(out)


def _f(v: float, digits: int) -> str:
    return '' if v is None or not math.isfinite(v) else f'{v:.{digits}f}'


def write_log(path: str | Path, actions: list[LogAction], meta: LogMeta, epc: str = SIM_EPC,
              channels_hz: tuple[float, ...] = ()) -> Path:
    """Write ``actions`` in the layout of the module doc (times µs, phases µrad, positions 0.1 mm).

    ``channels_hz``: the hop table; a read on one of its carriers gets its 1-based index as ``channel``.
    Truth columns are written when every action has ``start`` and ``pose``.
    """
    if not _EPC.match(epc):
        raise ValueError(f'epc {epc!r} is not an EPC (hex digits, a multiple of 4)')
    path = Path(path)
    truth = bool(actions) and all(a.start is not None and a.pose is not None for a in actions)
    index = {round(f): j + 1 for j, f in enumerate(channels_hz)}
    cols = COLUMNS if truth else COLUMNS[:-len(TRUTH)]
    head = [f'# format: {FORMAT}', f'# convention: {meta.convention}', f'# wrap: {meta.wrap}', f'# epc: {epc}']
    if meta.carrier_mhz is not None:
        head.append(f'# carrier_mhz: {meta.carrier_mhz:.3f}')
    if channels_hz:
        head.append('# channels_mhz: ' + ' '.join(f'{f / 1e6:.3f}' for f in channels_hz))

    def pose_cells(p: np.ndarray | None) -> list[str]:
        return [] if not truth else ['', '', ''] if p is None else [_f(p[0], 4), _f(p[1], 4), _f(p[2], 6)]

    rows = []
    for a in actions:
        s = a.stream
        if a.kind is CommandKind.MOVE:
            rows.append([_f(s.t_start, 6), '', '', '', '', '', '', 'move_start', _f(a.value, 4), *pose_cells(a.start)])
        else:
            rows.append([_f(s.t_start, 6), '', '', '', '', '', '', 'turn', _f(math.degrees(a.value), 4),
                         *pose_cells(a.pose)])
        carrier = s.carrier_hz if s.carrier_hz is not None else np.full(len(s), np.nan)
        ant = a.antenna if a.antenna.size == len(s) else np.ones(len(s), int)
        for j in range(len(s)):
            ch = index.get(round(carrier[j]), '') if math.isfinite(carrier[j]) else ''
            xy = pose_cells(None) if s.xy is None else pose_cells(np.array([s.xy[j, 0], s.xy[j, 1], math.nan]))
            rows.append([_f(s.t[j], 6), epc, str(int(ant[j])), str(ch), _f(carrier[j] / 1e6, 3), _f(s.phase[j], 6),
                         _f(s.rssi[j], 2), '', '', *xy])
        if a.kind is CommandKind.MOVE:
            rows.append([_f(s.t_end, 6), '', '', '', '', '', '', 'move_end', '', *pose_cells(a.pose)])
    with path.open('w', newline='', encoding='utf-8') as f:
        f.write('\n'.join(head) + '\n')
        w = csv.writer(f, lineterminator='\n')
        w.writerow(cols)
        w.writerows(rows)
    return path


def action_from_output(seq: int, cmd: Command, out: ReaderOutput, start: np.ndarray, step_m: float) -> LogAction:
    """A ``LogAction`` from one simulated action (``SimReader.execute``): truth from the simulator."""
    value = step_m if cmd.kind is CommandKind.MOVE else out.result.turn
    return LogAction(cmd.kind, seq, value, out.stream, 0, np.ones(len(out.stream), int),
                     np.asarray(start, float).copy(), out.pose.copy())


# -- the shipped example ---------------------------------------------------------------------------------------

EXAMPLE_CHANNELS = tuple(920.625e6 + 0.5e6 * j for j in range(8))
EXAMPLE_READER = PhaseModel(carrier_hz=920.625e6, wrap_period=2.0 * math.pi, s_theta=0.015, convention='llrp')
EXAMPLE_PLAN = ('move',) * 4 + (math.radians(20.0),) + ('move',) * 4   # 4 MOVEs, TURN 20° left, 4 MOVEs
EXAMPLE_STEP_M = 0.2


def simulate_walk(seed: int = 0, plan: tuple = EXAMPLE_PLAN, step_m: float = EXAMPLE_STEP_M,
                  reader: PhaseModel = EXAMPLE_READER, hop_dwell_s: float = 0.2) -> list[LogAction]:
    """A walk past a tag 1 m to the side, read by a hopping LLRP reader (``SimReader``), as log actions.

    ``plan``: 'move' or a turn angle (rad) per action. Small motion errors (s_r 2 mm, s_a 0.5°), 360° beam.
    """
    world = WorldParams(phase=reader, s_step=step_m, s_r=0.002, s_a=math.radians(0.5), beam_width=2.0 * math.pi,
                        channels_hz=EXAMPLE_CHANNELS if hop_dwell_s > 0 else (), hop_dwell_s=hop_dwell_s)
    sim = SimReader(world, np.random.default_rng(seed), start=np.array([-1.0, -1.0, 0.0]))
    out = []
    for seq, step in enumerate(plan, start=1):
        cmd = Command(CommandKind.MOVE, seq=seq) if step == 'move' else Command(CommandKind.TURN, float(step), seq)
        start = sim.pose.copy()
        out.append(action_from_output(seq, cmd, sim.execute(cmd), start, step_m))
    return out


def write_example(path: str | Path, seed: int = 0) -> Path:
    """(Re)write the shipped example log ``data/rfid/example-walk.csv`` (``simulate_walk(seed)``)."""
    meta = LogMeta(convention=EXAMPLE_READER.convention, wrap='2pi', carrier_mhz=EXAMPLE_READER.carrier_hz / 1e6)
    return write_log(path, simulate_walk(seed), meta, SIM_EPC, EXAMPLE_CHANNELS)


# -- replay ------------------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class ReplayStep:
    """One action of the log as the reader would answer it: the step result and, with truth, the user's counters."""

    action: LogAction
    result: StepResult
    steps: int                  # MOVEs so far
    turns: int                  # TURNs so far
    distance_m: float           # walked so far (truth; NaN without it)


class LogReplay:
    """The log's actions in order, each due once ``(t_end − first t_start) / rate`` has passed since ``begin``.

    Each MOVE's stream goes through one ``PhaseProcessor`` (its online noise learnt over the log's MOVEs), so the
    results are those of ``track-experiment rfid-reader --set file=``; a TURN's result is the logged turn, usable
    when the tag was read after it. ``found``: the truth within ``found_radius`` of the tag (never without truth).
    """

    def __init__(self, log: ReaderLog, unwrap: UnwrapConfig, found_radius: float = 0.2) -> None:
        self.log = log
        self.processor = PhaseProcessor(unwrap)
        self.found_radius = found_radius
        self.t0 = log.actions[0].stream.t_start if log.actions else 0.0
        self.begin: float | None = None
        self.next = 0
        self.steps = self.turns = 0
        self.distance = 0.0 if log.has_truth else math.nan

    @property
    def done(self) -> bool:
        return self.next >= len(self.log.actions)

    def due_at(self, action: LogAction, rate: float) -> float:
        """The node time at which ``action`` is answered (``begin`` set)."""
        return (self.begin or 0.0) + (action.stream.t_end - self.t0) / rate

    def take_due(self, now: float, rate: float) -> list[ReplayStep]:
        """The actions due at node time ``now`` (the first call sets ``begin``), in order."""
        if self.begin is None:
            self.begin = now
        out = []
        while not self.done and self.due_at(self.log.actions[self.next], rate) <= now:
            out.append(self._answer(self.log.actions[self.next]))
            self.next += 1
        return out

    def _answer(self, a: LogAction) -> ReplayStep:
        found = a.pose is not None and math.hypot(*a.pose[:2]) <= self.found_radius
        if a.kind is CommandKind.TURN:
            self.turns += 1
            n = len(a.stream)
            res = StepResult(CommandKind.TURN, a.seq, turn=a.value, n_reads=n, ok=n > 0,
                             reason='' if n else 'tag not read this way', found=found)
        else:
            self.steps += 1
            if a.start is not None and a.pose is not None:
                self.distance += math.hypot(*(a.pose[:2] - a.start[:2]))
            e = self.processor.process(a.stream)
            res = StepResult(CommandKind.MOVE, a.seq, dphi=e.dphi, n_reads=e.n_reads, n_outliers=e.n_outliers,
                             ok=e.ok, reason=e.reason, found=found, dphi_std=e.dphi_std, relocks=e.relocks)
        return ReplayStep(a, res, self.steps, self.turns, self.distance)
