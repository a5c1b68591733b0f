"""Simulated world, user and reader (Section VI): the reader side of the step-by-step protocol.

World: the tag at the origin, optional axis-aligned rectangular obstacles (they block walking, not
the radio), the user ``start_distance`` (10 m) away in a random direction and facing.

Reads: within ``max_range`` and inside the half-power beam (|bearing| ≤ ``beam_width``/2; 180° in
the paper's simulations, 68° its antenna) or closer than ``back_lobe_range``; Poisson at
``read_rate`` (≈ 300/s); phase wrap(−(4π/λ)d + φ₀ + N(0, s_θ²)) with a per-run φ₀, an outlier
uniform in (0, P] with ``outlier_prob``; RSSI = ``rssi_1m`` − 40 log₁₀ d + N(0, 2²) dBm.

User (worst-case errors of Section VI): at the start turns by ``scan_step`` (30°) until the tag is
read. TURN: the suggested angle, else the first of suggestion ± j·``detour_step`` (15°) that is free
(no obstacle within ``lookahead`` + ``clearance``) and read (``beam_margin`` inside the beam),
reported as the turn made. MOVE: heading error n_a ~ N(0, s_a²); ``step_model='eq1'`` (eqs. 1–2):
E = S + k̂·s_step + r(cos θ_m, sin θ_m), r ~ N(0, s_r²), θ_m uniform; ``'eq20'`` (eq. 20): (s_step +
r) along the heading; at ``walk_speed``; a step into an obstacle stops 5 cm before it. Found: within
``found_radius`` (0.2 m, Fig. 8) after a MOVE. An unusable MOVE (``protocol.step_result_problem``)
is undone (the user walks back).

Real readers (off by default, then not one extra random draw): ``phase.convention`` 'llrp'; hopping
(``channels_hz``, ``hop_dwell_s``; per channel k_c = 4π f_c/c and offset o_c: φ = s·k_c·d + φ₀ +
o_c); lasting phase steps (``phase_step_rate`` a second, size ±U[``phase_step_size``]);
``phase.s_theta``; Student-t read noise (``noise_dof`` ν, scale held over ``noise_burst_s``);
``ReaderOutput.truth_dphi`` (the geometric dφ, eq. 6). In full: docs/MODULES.md, "The simulated RFID
world and user".
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from track_core.filters import wrap_angle
from track_core.rfid.phase import CARRIER_RANGE_HZ, PhaseModel
from track_core.rfid.protocol import Command, CommandKind, StepResult, step_result_problem
from track_core.rfid.signal import DphiEstimate, PhaseProcessor, PhaseStream, UnwrapConfig


@dataclass(frozen=True)
class Rect:
    """Axis-aligned rectangle [xmin, xmax] × [ymin, ymax] (m)."""

    xmin: float
    ymin: float
    xmax: float
    ymax: float

    def __post_init__(self) -> None:
        if not (self.xmin < self.xmax and self.ymin < self.ymax):
            raise ValueError(f'Rect needs xmin < xmax and ymin < ymax, got {self}')

    def inflate(self, m: float) -> Rect:
        return Rect(self.xmin - m, self.ymin - m, self.xmax + m, self.ymax + m)

    def contains(self, p: np.ndarray) -> bool:
        return bool(self.xmin <= p[0] <= self.xmax and self.ymin <= p[1] <= self.ymax)

    def segment_entry(self, p: np.ndarray, q: np.ndarray) -> float | None:
        """Fraction t ∈ [0, 1] at which the segment p→q enters the rectangle (Liang–Barsky), or None."""
        d = q - p
        t0, t1 = 0.0, 1.0
        for pk, qk in ((-d[0], p[0] - self.xmin), (d[0], self.xmax - p[0]),
                       (-d[1], p[1] - self.ymin), (d[1], self.ymax - p[1])):
            if pk == 0.0:
                if qk < 0.0:
                    return None
                continue
            t = qk / pk
            if pk < 0.0:
                t0 = max(t0, t)
            else:
                t1 = min(t1, t)
            if t0 > t1:
                return None
        return t0


def office_obstacles() -> tuple[Rect, ...]:
    """The obstacle variant: an office around the tag (axis-aligned rectangles, metres).

    Eight 1.6 m × 0.8 m desks on a 5 m ring (every 45°) and four 0.6 m pillars on a 2.5 m ring:
    with the 0.3 m clearance, about half of the straight lines from the 10 m start circle to the
    tag cross a desk, and the user has to walk around it.
    """
    out = []
    for k in range(8):
        th = k * math.pi / 4.0
        cx, cy = 5.0 * math.cos(th), 5.0 * math.sin(th)
        hw, hh = (0.4, 0.8) if abs(math.cos(th)) > 0.9 else (0.8, 0.4) if abs(math.sin(th)) > 0.9 else (0.6, 0.6)
        out.append(Rect(cx - hw, cy - hh, cx + hw, cy + hh))
    for k in range(4):
        th = math.pi / 8.0 + k * math.pi / 2.0
        cx, cy = 2.5 * math.cos(th), 2.5 * math.sin(th)
        out.append(Rect(cx - 0.3, cy - 0.3, cx + 0.3, cy + 0.3))
    return tuple(out)


@dataclass(frozen=True)
class WorldParams:
    """World, reader and user parameters; defaults are the paper's simulation (Section VI)."""

    phase: PhaseModel = field(default_factory=PhaseModel)
    start_distance: float = 10.0
    beam_width: float = math.pi            # half-power beam width (rad): 180° simulated, 68° real
    max_range: float = 15.0
    back_lobe_range: float = 2.0
    read_rate: float = 300.0               # reads/s
    outlier_prob: float = 0.01
    rssi_1m: float = -35.0
    walk_speed: float = 1.0                # m/s
    turn_read_s: float = 0.2               # reads collected after a TURN to check the signal
    s_step: float = 0.5
    s_r: float = 0.1
    s_a: float = math.radians(11.5)
    scan_step: float = math.radians(30.0)  # rotation per try when searching for the signal at the start
    detour_step: float = math.radians(15.0)  # grid of directions tried after a TURN (blocked / not read)
    clearance: float = 0.3
    lookahead: float = 2.0                 # how far ahead the user sees an obstacle in the way (m)
    beam_margin: float = math.radians(15.0)  # a detour prefers the tag this far inside the beam's edge
    found_radius: float = 0.2
    obstacles: tuple[Rect, ...] = ()
    step_model: str = 'eq1'                # 'eq1': eqs. 1–2; 'eq20': eq. 20's (s_step + r) along the heading
    channels_hz: tuple[float, ...] = ()    # hopping carriers (Hz); () = one carrier, phase.carrier_hz
    hop_dwell_s: float = 0.0               # dwell per channel when hopping (s)
    phase_step_rate: float = 0.0           # lasting multipath phase steps per second of reads
    phase_step_size: tuple[float, float] = (0.0, 0.0)   # step magnitude uniform in [lo, hi] (rad), random sign
    noise_dof: float = 0.0                 # > 0: Student-t read noise with this ν (0 = Gaussian)
    noise_burst_s: float = 0.03            # time over which the t noise keeps its scale (s)

    def __post_init__(self) -> None:
        if not (0.0 < self.beam_width <= 2.0 * math.pi):
            raise ValueError(f'beam_width must be in (0, 2π], got {self.beam_width}')
        if self.start_distance <= 0.0 or self.start_distance > self.max_range:
            raise ValueError('start_distance must be in (0, max_range]')
        if self.read_rate <= 0.0 or self.walk_speed <= 0.0 or self.found_radius <= 0.0:
            raise ValueError('read_rate, walk_speed and found_radius must be > 0')
        if not (0.0 <= self.outlier_prob < 1.0):
            raise ValueError(f'outlier_prob must be in [0, 1), got {self.outlier_prob}')
        if not (0.0 < self.scan_step <= math.pi and 0.0 < self.detour_step <= math.pi):
            raise ValueError('scan_step and detour_step must be in (0, π]')
        if self.channels_hz and (len(self.channels_hz) < 2 or not self.hop_dwell_s > 0.0):
            raise ValueError('hopping needs at least 2 channels_hz and hop_dwell_s > 0')
        lo, hi = CARRIER_RANGE_HZ
        if any(not (lo <= f <= hi) for f in self.channels_hz):
            raise ValueError(f'channels_hz must be within {lo / 1e6:g}–{hi / 1e6:g} MHz, got {self.channels_hz}')
        a, b = self.phase_step_size
        if self.phase_step_rate < 0.0 or not (0.0 <= a <= b):
            raise ValueError('phase_step_rate must be >= 0 and phase_step_size 0 <= lo <= hi')
        if not (self.noise_dof >= 0.0 and self.noise_burst_s > 0.0):
            raise ValueError('noise_dof must be >= 0 and noise_burst_s > 0')

    @property
    def hopping(self) -> bool:
        return len(self.channels_hz) >= 2


@dataclass(frozen=True)
class ReaderOutput:
    result: StepResult
    stream: PhaseStream
    pose: np.ndarray               # true (x, y, heading) after the action, for evaluation only
    estimate: DphiEstimate | None = None
    truth_dphi: float = math.nan   # MOVE: geometric dφ of the step walked (eq. 6, reference carrier)


def read_mask(params: WorldParams, xy: np.ndarray, heading: np.ndarray | float) -> np.ndarray:
    """Whether the tag (origin) is read from positions ``xy`` (..., 2) facing ``heading``."""
    xy = np.asarray(xy, dtype=float)
    d = np.hypot(xy[..., 0], xy[..., 1])
    rel = wrap_angle(np.arctan2(-xy[..., 1], -xy[..., 0]) - heading)
    in_beam = np.abs(rel) <= 0.5 * params.beam_width
    return (d <= params.max_range) & (in_beam | (d <= params.back_lobe_range))


class SimReader:
    """The simulated user holding the reader; ``execute(command)`` performs one action."""

    def __init__(self, params: WorldParams, rng: np.random.Generator, start: np.ndarray | None = None,
                 unwrap: UnwrapConfig | None = None) -> None:
        self.params = params
        self.rng = rng
        self.unwrap = unwrap or UnwrapConfig.for_model(params.phase)
        self.processor = PhaseProcessor(self.unwrap)
        if start is None:
            for _ in range(1000):
                th = rng.uniform(-math.pi, math.pi)
                xy = params.start_distance * np.array([math.cos(th), math.sin(th)])
                if not self._blocked_point(xy):
                    break
            else:
                raise ValueError('no free start position: the obstacles cover the start circle')
            start = np.array([xy[0], xy[1], rng.uniform(-math.pi, math.pi)])
        self.pose = np.asarray(start, dtype=float).copy()
        self.offset = rng.uniform(0.0, 2.0 * math.pi)
        self.t = 0.0
        self.steps = 0
        self.turns = 0
        self.repeats = 0
        self.distance = 0.0
        self.route = [self.pose[:2].copy()]
        self._detour_sign = 0.0
        self._initial_scan()
        self.step_offset = 0.0                    # lasting multipath phase steps so far (rad)
        if params.hopping:                        # drawn only when hopping: the paper's runs draw nothing more
            self.channel_offsets = rng.uniform(0.0, 2.0 * math.pi, len(params.channels_hz))
            self._hop_phase = float(rng.uniform(0.0, params.hop_dwell_s))
            self._dwell = (-1, int(rng.integers(len(params.channels_hz))))   # (dwell index, channel)

    # -- geometry -----------------------------------------------------------------------------
    def _blocked_point(self, xy: np.ndarray) -> bool:
        return any(r.inflate(self.params.clearance).contains(xy) for r in self.params.obstacles)

    def _free(self, heading: float, ahead: float | None = None) -> bool:
        """The next ``ahead`` metres that way (default one step) stay ``clearance`` from every obstacle.

        A user already closer than that to an obstacle (the step noise took them there) uses
        their current distance minus 1 cm instead, so that they can always walk away from it.
        """
        p = self.params
        if not p.obstacles:
            return True
        a = self.pose[:2]
        b = a + (p.s_step if ahead is None else ahead) * np.array([math.cos(heading), math.sin(heading)])
        for r in p.obstacles:
            gap = math.hypot(max(r.xmin - a[0], 0.0, a[0] - r.xmax), max(r.ymin - a[1], 0.0, a[1] - r.ymax))
            if r.inflate(max(0.0, min(p.clearance, gap - 0.01))).segment_entry(a, b) is not None:
                return False
        return True

    def _reads(self, heading: float, margin: float = 0.0) -> bool:
        """The tag is read facing ``heading``; with ``margin``, at least that far inside the beam's edge."""
        p = self.params
        xy = self.pose[:2]
        if margin > 0.0 and np.hypot(*xy) > p.back_lobe_range:
            rel = abs(float(wrap_angle(math.atan2(-xy[1], -xy[0]) - heading)))
            if rel > 0.5 * p.beam_width - margin:
                return False
        return bool(read_mask(p, xy, heading))

    def distance_to_tag(self) -> float:
        return float(np.hypot(*self.pose[:2]))

    def _initial_scan(self) -> None:
        p = self.params
        for _ in range(math.ceil(2.0 * math.pi / p.scan_step) + 1):
            if self._reads(self.pose[2]):
                return
            self.pose[2] = float(wrap_angle(self.pose[2] + p.scan_step))
            self.turns += 1
        raise ValueError('the tag is read in no direction from the start (out of range?)')

    # -- reads ---------------------------------------------------------------------------------
    def _stream(self, xy0: np.ndarray, xy1: np.ndarray, heading: float, duration: float) -> PhaseStream:
        p, rng = self.params, self.rng
        t0 = self.t
        n_max = int(p.read_rate * duration * 1.5 + 20)
        times = np.cumsum(rng.exponential(1.0 / p.read_rate, n_max))
        times = times[times <= duration]
        f = (times / duration)[:, None] if duration > 0 else np.zeros((times.size, 1))
        xy = xy0 + f * (xy1 - xy0)
        keep = read_mask(p, xy, heading)
        times, xy = times[keep], xy[keep]
        d = np.hypot(xy[:, 0], xy[:, 1])
        noise = rng.normal(0.0, p.phase.s_theta, d.size)
        if p.noise_dof > 0.0:
            noise = noise * self._noise_scale(t0 + times)
        out = rng.random(d.size) < p.outlier_prob
        wild = rng.uniform(0.0, p.phase.wrap_period, int(out.sum()))
        rssi = p.rssi_1m - 40.0 * np.log10(np.maximum(d, 0.05)) + rng.normal(0.0, 2.0, d.size)
        carrier, extra = None, 0.0
        if p.hopping:
            chan = self._channels(t0 + times)
            carrier = np.asarray(p.channels_hz)[chan]
            extra = self.channel_offsets[chan]
        if p.phase_step_rate > 0.0:
            extra = extra + self._phase_steps(times, duration)
        ph = p.phase.phase(d, self.offset, carrier) + noise + extra
        ph[out] = wild
        self.t = t0 + duration
        return PhaseStream(t0 + times, p.phase.wrap(ph), rssi, t0, t0 + duration, carrier, xy)

    def _channels(self, times: np.ndarray) -> np.ndarray:
        """Channel index of each read: one channel per dwell, each dwell on another channel than the last."""
        p = self.params
        dwell = np.floor((times + self._hop_phase) / p.hop_dwell_s).astype(int)
        keys = np.unique(dwell)
        chans = np.empty(keys.size, dtype=int)
        for j, k in enumerate(keys):      # one draw per new dwell (a few per step), not per read
            if k > self._dwell[0]:
                c = int(self.rng.integers(len(p.channels_hz) - 1))
                self._dwell = (int(k), c + int(c >= self._dwell[1]))
            chans[j] = self._dwell[1]
        return chans[np.searchsorted(keys, dwell)]

    def _noise_scale(self, times: np.ndarray) -> np.ndarray:
        """1/√(g/ν) per read, g ~ χ²_ν drawn once per burst of ``noise_burst_s`` reader time (module doc)."""
        p = self.params
        burst = np.floor(times / p.noise_burst_s).astype(np.int64)
        keys, inv = np.unique(burst, return_inverse=True)
        g = self.rng.chisquare(p.noise_dof, keys.size) / p.noise_dof
        return 1.0 / np.sqrt(np.maximum(g, 1e-12))[inv]

    def _phase_steps(self, times: np.ndarray, duration: float) -> np.ndarray:
        """The lasting phase step offset of each read (rad): earlier steps plus those during this action."""
        p, rng = self.params, self.rng
        k = int(rng.poisson(p.phase_step_rate * duration))
        at = np.sort(rng.uniform(0.0, duration, k))
        size = rng.uniform(*p.phase_step_size, k) * rng.choice([-1.0, 1.0], k)
        cum = np.concatenate([[0.0], np.cumsum(size)])
        offs = self.step_offset + cum[np.searchsorted(at, times, side='right')]
        self.step_offset += float(cum[-1])
        return offs

    # -- actions -------------------------------------------------------------------------------
    def execute(self, cmd: Command) -> ReaderOutput:
        if cmd.kind is CommandKind.TURN:
            return self._turn(cmd)
        if cmd.kind is CommandKind.MOVE:
            return self._move(cmd)
        return ReaderOutput(StepResult(cmd.kind, cmd.seq, found=self.found()), PhaseStream.empty(self.t, self.t),
                            self.pose.copy())

    def found(self) -> bool:
        return self.distance_to_tag() <= self.params.found_radius

    def _turn(self, cmd: Command) -> ReaderOutput:
        p = self.params
        old = float(self.pose[2])
        want = old + cmd.angle
        toward_old = -1.0 if wrap_angle(cmd.angle) > 0 else 1.0
        first = self._detour_sign if self._detour_sign != 0.0 else toward_old
        chosen, fallback = None, None
        grid = [want + sgn * j * p.detour_step for j in range(math.floor(math.pi / p.detour_step) + 1)
                for sgn in ((0.0,) if j == 0 else (first, -first))]
        # plan around what is seen ahead, else just the next step; prefer reads well inside the beam
        for ahead, margin in ((p.lookahead, p.beam_margin), (p.lookahead, 0.0), (None, p.beam_margin), (None, 0.0)):
            for cand in grid:
                if not self._free(cand, ahead):
                    continue
                if fallback is None and ahead is None:
                    fallback = cand
                if self._reads(cand, margin):
                    chosen = cand
                    break
            if chosen is not None:
                break
        if chosen is None:
            chosen = fallback if fallback is not None else want
        if p.obstacles:
            if not self._free(want, p.lookahead):
                dev = float(wrap_angle(chosen - want))
                if dev != 0.0:
                    self._detour_sign = math.copysign(1.0, dev)
            else:
                self._detour_sign = 0.0
        self.turns += 1 + int(chosen != want)   # the suggested turn, then one more to the way taken
        reported = float(wrap_angle(chosen - old))
        self.pose[2] = float(wrap_angle(chosen))
        stream = self._stream(self.pose[:2], self.pose[:2], self.pose[2], p.turn_read_s)
        return ReaderOutput(StepResult(CommandKind.TURN, cmd.seq, turn=reported, n_reads=len(stream),
                                       ok=len(stream) > 0, reason='' if len(stream) else 'tag not read this way',
                                       found=self.found()), stream, self.pose.copy())

    def _move(self, cmd: Command) -> ReaderOutput:
        p, rng = self.params, self.rng
        start = self.pose.copy()
        head = float(wrap_angle(start[2] + rng.normal(0.0, p.s_a)))
        a = start[:2]
        if p.step_model == 'eq1':      # eqs. 1–2: E = S + k̂ s_step + r (cos θ_m, sin θ_m)
            th = rng.uniform(0.0, 2.0 * math.pi)
            b = a + p.s_step * np.array([math.cos(head), math.sin(head)]) \
                + rng.normal(0.0, p.s_r) * np.array([math.cos(th), math.sin(th)])
        else:                          # eq. 20's model: (s_step + r) along the heading
            b = a + max(0.0, p.s_step + rng.normal(0.0, p.s_r)) * np.array([math.cos(head), math.sin(head)])
        length = float(np.hypot(*(b - a)))   # the facing direction stays ``head`` (eq. 1's k̂)
        for r in p.obstacles:
            t = r.segment_entry(a, b)
            if t is not None:
                f = max(0.0, t - 0.05 / max(length, 1e-9))
                b = a + f * (b - a)
                length = float(np.hypot(*(b - a)))
        stream = self._stream(a, b, head, max(length, 1e-3) / p.walk_speed)
        est = self.processor.process(stream)
        self.pose = np.array([b[0], b[1], head])
        self.steps += 1
        self.distance += length
        res = StepResult(CommandKind.MOVE, cmd.seq, dphi=est.dphi, n_reads=est.n_reads, n_outliers=est.n_outliers,
                         ok=est.ok, reason=est.reason, found=self.found(), dphi_std=est.dphi_std,
                         relocks=est.relocks)
        truth = p.phase.k * (float(np.hypot(*b)) - float(np.hypot(*a)))
        if not res.found and step_result_problem(res) is not None:
            self.pose = start                     # unusable step: go back to where it started
            self.distance += length
            self.repeats += 1
        self.route.append(self.pose[:2].copy())
        return ReaderOutput(res, stream, self.pose.copy(), est, truth)
