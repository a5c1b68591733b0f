"""Reader signal processing: one MOVE's stream of wrapped phase reads → the step's dφ (eq. 6).

The reader reads the tag ~300 times a second while the user walks one step (Section II, Figs. 1–2).
``process_move`` unwraps the stream, rejects outliers, fits both ends and returns dφ =
−(φ_end − φ_start) in the sign of eq. 6 (see ``phase``), or "signal lost"/"invalid" with a reason.

- Lock: the first read agreeing with its next two (wrapped differences ≤ the gate g; wrap(·) maps
  into (−P/2, P/2], P the reader's wrap period). Track: an α–β tracker (α = 0.3, β = 0.05, slope
  in rad/s) predicts û; r = wrap(φ − û); |r| > g = ``gate``·P (0.15·P) is an outlier, dropped
  without moving the tracker; accepted reads unwrap to û + r.
- Invalid (dφ NaN, with the reason): more than ``max_consecutive_outliers`` rejects in a row, a gap
  over ``max_gap_s``, an outlier share over ``max_outlier_fraction``. Signal lost: no reads, fewer
  than ``min_reads``, or reads not covering the step (``max_edge_gap_s`` from the button presses).
- Ends: least-squares lines through the first and last ``smooth_window`` (20) accepted reads,
  refitted once without reads > 3 MAD-σ off, at ``t_start``/``t_end`` (else the end reads).

Real readers (off by default: bit for bit the rules above for the paper's reader;
``UnwrapConfig.real_reader(phase)`` turns them on). ``sign`` s: φ = s·k·d + φ₀ (+1 for LLRP/Impinj).
- Carriers: the state is the unwrapped phase in the reference carrier's units; a read on carrier c
  is predicted as ρ_c·Û + Δ_c (ρ_c = k_c/k_ref; Δ_c from ``channel_lock_reads`` agreeing reads);
  dφ = s·Σ_segments (end fit − start fit)/ρ_c, segments under ``min_segment_reads`` dropped.
- ``relock_reads``: that many consecutive rejects agreeing within g/2 re-lock (``relocks``); the
  step is bridged by ``step_bridge``: 'wrapped' (jump by the wrapped step) or 'join' (new segment).
- ``noise='online'``: σ̂ = median over ``noise_memory`` MOVEs of 1.4826·MAD of end-fit residuals;
  it sets g = min(``gate``·P, max(``min_gate``, ``gate_sigmas``·σ̂)), the end window and
  ``dphi_std`` (θ_d's std in eq. 11; NaN with ``noise='fixed'``). ``noise='robust'``: Student-t
  reads (ν, scale learnt) plus wild reads of share ``outlier_rate``, gated where both are equally
  likely (``t_gate``); ``dphi_std`` from each end's spread × ``dphi_std_factor``, + P²/12 a re-lock.
Reasons and measurements: docs/results/rfid.md, "Signal processing in full".
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field
from enum import Enum

import numpy as np


class StreamStatus(Enum):
    OK = 'ok'
    SIGNAL_LOST = 'signal_lost'   # no (or too few, or not covering) reads: back lobe / out of range
    INVALID = 'invalid'           # reads present but the unwrapped curve cannot be trusted


@dataclass(frozen=True)
class PhaseStream:
    """Reads of one action: times (s), wrapped phases (rad), RSSI (dBm), all the same length.

    ``carrier_hz``: the carrier of each read (Hz) for a hopping reader; None = every read on the
    reference carrier of the processing (``UnwrapConfig.carrier_hz``). ``xy``: where the reader was
    at each read, (n, 2) m (the simulator's truth, tag at the origin; for display, never processed);
    None = not known.
    """

    t: np.ndarray
    phase: np.ndarray
    rssi: np.ndarray
    t_start: float | None = None   # when the user pressed the button (start of the action)
    t_end: float | None = None     # when the action was confirmed
    carrier_hz: np.ndarray | None = None
    xy: np.ndarray | None = None

    def __post_init__(self) -> None:
        for name in ('t', 'phase', 'rssi'):
            object.__setattr__(self, name, np.asarray(getattr(self, name), dtype=float).reshape(-1))
        if not (self.t.size == self.phase.size == self.rssi.size):
            raise ValueError(f'PhaseStream: t, phase, rssi lengths differ ({self.t.size}, {self.phase.size}, '
                             f'{self.rssi.size})')
        if self.carrier_hz is not None:
            c = np.asarray(self.carrier_hz, dtype=float).reshape(-1)
            if c.size != self.t.size:
                raise ValueError(f'PhaseStream: carrier_hz has {c.size} values for {self.t.size} reads')
            object.__setattr__(self, 'carrier_hz', c)
        if self.xy is not None:
            xy = np.asarray(self.xy, dtype=float)
            if xy.shape != (self.t.size, 2):
                raise ValueError(f'PhaseStream: xy has shape {xy.shape} for {self.t.size} reads (need (n, 2))')
            object.__setattr__(self, 'xy', xy)

    def __len__(self) -> int:
        return int(self.t.size)

    @classmethod
    def empty(cls, t_start: float | None = None, t_end: float | None = None) -> PhaseStream:
        z = np.empty(0)
        return cls(z, z, z, t_start, t_end)


BRIDGES = ('wrapped', 'join')
NOISE_MODES = ('fixed', 'online', 'robust')
REAL_READER = {'relock_reads': 5, 'noise': 'robust'}   # ``UnwrapConfig.real_reader``


@dataclass(frozen=True)
class UnwrapConfig:
    """Parameters of ``process_move``; ``period`` is the reader's wrap period P (π or 2π).

    The defaults are the paper's reader; ``for_model`` takes period, sign and carrier from a
    ``PhaseModel``. See the module doc for the real-reader options.
    """

    period: float = math.pi
    gate: float = 0.15                 # outlier gate g as a fraction of P
    alpha: float = 0.3
    beta: float = 0.05
    smooth_window: int = 20            # reads per end fit
    min_reads: int = 10
    max_consecutive_outliers: int = 8
    max_gap_s: float = 0.15
    max_edge_gap_s: float = 0.15
    max_outlier_fraction: float = 0.3
    sign: float = -1.0                 # s of φ = s·k·d + φ₀: −1 the paper (eq. 3), +1 LLRP readers
    carrier_hz: float = 866.3e6        # reference carrier: dφ is k_ref·Δd; reads without a carrier are on it
    relock_reads: int = 0              # agreeing rejected reads that re-lock after a lasting step; 0 = never
    step_bridge: str = 'wrapped'       # 'wrapped' (the wrapped difference enters dφ) or 'join' (fits bridge it)
    channel_lock_reads: int = 3        # agreeing reads that lock a channel first read in this MOVE
    min_segment_reads: int = 5         # shorter segments are dropped
    noise: str = 'fixed'               # 'fixed': the paper's gate and fits; 'online': σ̂ from the data
    noise_prior: float = math.radians(5.5)  # σ̂ before the first MOVE (online)
    gate_sigmas: float = 6.0           # online gate: gate_sigmas·σ̂, within [min_gate, gate·P]
    min_gate: float = 0.15             # rad
    end_noise: float = 0.01            # online end-fit window: 2σ̂/√W ≤ end_noise (rad)
    noise_memory: int = 10             # MOVEs in the online noise estimate
    outlier_rate: float = 0.01         # robust gate: prior share of wild reads, uniform over P
    tail_dof: float = 0.0              # robust: ν of the t likelihood; 0 = learnt from the innovations
    min_tail_samples: int = 200        # robust: innovations needed before ν is learnt (before: ν = 2)
    dphi_std_factor: float = 1.0       # robust: dphi_std scale (module doc: calibration)

    def __post_init__(self) -> None:
        if not (0.0 < self.gate < 0.5):
            raise ValueError(f'gate must be in (0, 0.5) of the period (ambiguous beyond P/2), got {self.gate}')
        if self.period <= 0.0:
            raise ValueError(f'period must be > 0, got {self.period}')
        if self.smooth_window < 2 or self.min_reads < 3:
            raise ValueError('smooth_window must be >= 2 and min_reads >= 3')
        if self.sign not in (-1.0, 1.0):
            raise ValueError(f'sign must be -1 (paper) or +1 (LLRP), got {self.sign}')
        if self.step_bridge not in BRIDGES:
            raise ValueError(f'step_bridge must be one of {BRIDGES}, got {self.step_bridge!r}')
        if self.noise not in NOISE_MODES:
            raise ValueError(f'noise must be one of {NOISE_MODES}, got {self.noise!r}')
        if not (0.0 < self.outlier_rate < 0.5 and self.tail_dof >= 0.0 and self.min_tail_samples >= 20):
            raise ValueError('outlier_rate must be in (0, 0.5), tail_dof >= 0, min_tail_samples >= 20')
        if self.relock_reads < 0 or self.channel_lock_reads < 1 or self.min_segment_reads < 2:
            raise ValueError('relock_reads must be >= 0, channel_lock_reads >= 1, min_segment_reads >= 2')
        if not (self.carrier_hz > 0.0 and self.noise_prior > 0.0 and self.end_noise > 0.0 and self.min_gate > 0.0
                and self.gate_sigmas > 0.0 and self.noise_memory >= 1):
            raise ValueError('carrier_hz, noise_prior, end_noise, min_gate, gate_sigmas must be > 0, '
                             'noise_memory >= 1')

    @classmethod
    def for_model(cls, phase, **kw) -> UnwrapConfig:
        """Period, sign and reference carrier of a ``phase.PhaseModel``; the other fields from ``kw``."""
        kw.setdefault('noise_prior', max(phase.s_theta, 1e-4))
        return cls(period=phase.wrap_period, sign=phase.sign, carrier_hz=phase.carrier_hz, **kw)

    @classmethod
    def real_reader(cls, phase, **kw) -> UnwrapConfig:
        """``for_model`` with the real-reader processing on: re-lock after 5 reads, online noise."""
        return cls.for_model(phase, **{**REAL_READER, **kw})


@dataclass(frozen=True)
class DphiEstimate:
    """Result of processing one MOVE's stream."""

    status: StreamStatus
    dphi: float                       # eq. 6 sign; NaN unless status is OK
    reason: str = ''
    n_reads: int = 0
    n_outliers: int = 0
    unwrapped: np.ndarray = field(default_factory=lambda: np.empty(0))  # per read (its channel's units); NaN: not used
    accepted: np.ndarray = field(default_factory=lambda: np.empty(0, bool))
    relocks: int = 0                  # re-locks after a lasting phase step
    hops: int = 0                     # channel changes between the segments used
    dphi_std: float = math.nan        # std of dφ from the read noise (online noise only)
    noise_std: float = math.nan       # per-read noise σ̂ used (online noise only)

    @property
    def ok(self) -> bool:
        return self.status is StreamStatus.OK


def _wrap_c(x: float, p: float, half: float) -> float:
    """Wrap into (−P/2, P/2]."""
    return half - (half - x) % p


def _line(t: np.ndarray, u: np.ndarray) -> tuple[float, float, float]:
    tm, um = float(t.mean()), float(u.mean())
    tc = t - tm
    den = float(tc @ tc)
    return tm, um, (float(tc @ (u - um)) / den if den > 0 else 0.0)


def _end_keep(t: np.ndarray, u: np.ndarray) -> np.ndarray | None:
    """The reads kept by the end fit's refit (None: all): those within 3 MAD-σ of the first line."""
    tm, um, b = _line(t, u)
    res = u - (um + b * (t - tm))
    keep = np.abs(res) <= max(3.0 * 1.4826 * float(np.median(np.abs(res - np.median(res)))), 1e-3)
    return keep if 3 <= keep.sum() < t.size else None


def _end_value(t: np.ndarray, u: np.ndarray, at: float) -> float:
    """Line through (t, u) at ``at``: least squares, then once more without reads off by > 3 MAD-σ."""
    keep = _end_keep(t, u)
    if keep is not None:
        t, u = t[keep], u[keep]
    tm, um, b = _line(t, u)
    return um + b * (at - tm)


def _end_var_factor(t: np.ndarray, u: np.ndarray, at: float) -> float:
    """Var(end value)/σ² of the fit ``_end_value`` makes: 1/n + (at − t̄)²/Σ(tᵢ − t̄)²."""
    keep = _end_keep(t, u)
    if keep is not None:
        t = t[keep]
    tc = t - t.mean()
    den = float(tc @ tc)
    return 1.0 / t.size + ((at - float(t.mean())) ** 2 / den if den > 0 else 0.0)


def _end_spread(t: np.ndarray, u: np.ndarray) -> float:
    """RMS residual of the end fit ``_end_value`` makes (over the reads it keeps, n − 2 dof); NaN below 4 reads."""
    keep = _end_keep(t, u)
    if keep is not None:
        t, u = t[keep], u[keep]
    if t.size < 4:
        return math.nan
    tm, um, b = _line(t, u)
    res = u - (um + b * (t - tm))
    return math.sqrt(float(res @ res) / (t.size - 2.0))


def _fit_residuals(t: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Residuals of a line fit, scaled by √(n/(n − 2)) (two fitted parameters); empty below 4 reads."""
    if t.size < 4:
        return np.empty(0)
    tm, um, b = _line(t, u)
    return (u - (um + b * (t - tm))) * math.sqrt(t.size / (t.size - 2.0))


def _fail(status: StreamStatus, reason: str, n: int, n_out: int = 0, un=None, acc=None, relocks: int = 0
          ) -> DphiEstimate:
    return DphiEstimate(status, math.nan, reason, n, n_out,
                        np.full(n, np.nan) if un is None else un,
                        np.zeros(n, bool) if acc is None else acc, relocks)


def _precheck(stream: PhaseStream, cfg: UnwrapConfig) -> DphiEstimate | None:
    """Signal lost or malformed before any unwrapping; None when the stream can be unwrapped."""
    n, t = len(stream), stream.t
    problem = None
    if n == 0:
        problem = (StreamStatus.SIGNAL_LOST, 'signal lost: no reads during the step (tag in the back lobe or out '
                   'of range)')
    elif not (np.all(np.isfinite(t)) and np.all(np.isfinite(stream.phase))):
        problem = (StreamStatus.INVALID, 'non-finite time or phase in the stream')
    elif stream.carrier_hz is not None and not np.all(stream.carrier_hz > 0.0):
        problem = (StreamStatus.INVALID, 'non-positive or non-finite carrier in the stream')
    elif np.any(np.diff(t) < 0):
        problem = (StreamStatus.INVALID, 'read times are not in order')
    elif 2 * (distinct := np.unique(t).size) < n:   # the phase rate and the end fits need each read's time
        problem = (StreamStatus.INVALID, f'{n} reads carry only {distinct} distinct times: the reader stamps '
                   'reads in batches (each read needs its own time)')
    elif n < cfg.min_reads:
        problem = (StreamStatus.SIGNAL_LOST, f'signal lost: only {n} reads (< {cfg.min_reads})')
    elif stream.t_start is not None and t[0] - stream.t_start > cfg.max_edge_gap_s:
        problem = (StreamStatus.SIGNAL_LOST,
                   f'signal lost: first read {1e3 * (t[0] - stream.t_start):.0f} ms after the step started')
    elif stream.t_end is not None and stream.t_end - t[-1] > cfg.max_edge_gap_s:
        problem = (StreamStatus.SIGNAL_LOST,
                   f'signal lost: last read {1e3 * (stream.t_end - t[-1]):.0f} ms before the step ended')
    return None if problem is None else _fail(*problem, n)


def _lock(tl: list, pl: list, ch: list, p: float, g: float) -> tuple[int, float]:
    """Step 1: the first read agreeing with its two successors (same channel), and the initial slope (rad/s)."""
    half = 0.5 * p
    n = len(pl)
    start = next((i for i in range(n - 2) if ch[i] == ch[i + 1] == ch[i + 2]
                  and abs(_wrap_c(pl[i + 1] - pl[i], p, half)) <= g
                  and abs(_wrap_c(pl[i + 2] - pl[i + 1], p, half)) <= g), -1)
    if start < 0:
        return -1, 0.0
    # median over the first reads of wrapped 5-read differences per second (robust to outliers)
    inc = [_wrap_c(pl[i + 5] - pl[i], p, half) / (tl[i + 5] - tl[i])
           for i in range(start, min(n - 5, start + 20)) if tl[i + 5] > tl[i] and ch[i + 5] == ch[i]]
    return start, float(np.median(inc)) if inc else 0.0


@dataclass
class _Track:
    """What the sequential pass produces (lists, one entry per read)."""

    un: list
    acc: list
    seg: list
    relocks: int = 0
    reason: str = ''
    inn: list = field(default_factory=list)   # innovations of the reads on known channels (robust noise)


def _track(tl: list, pl: list, rho: list, ch: list, start: int, v: float, dtn: float, cfg: UnwrapConfig,
           g: float) -> _Track:
    """Steps 2–5 with the real-reader additions (module doc): α–β tracker on U, per-channel offsets,
    outlier gate, re-lock after a lasting step. ``rho`` = k_c/k_ref per read, ``ch`` a channel key per read."""
    p, half = float(cfg.period), 0.5 * float(cfg.period)
    out = _Track([math.nan] * len(pl), [False] * len(pl), [-1] * len(pl))
    un, acc, seg = out.un, out.acc, out.seg
    off = {ch[start]: 0.0}
    u = pl[start] / rho[start]          # state in reference units (exactly pl[start] on the reference carrier)
    v = v / rho[start]
    un[start], acc[start], seg[start] = pl[start], True, 0
    t_last, cur, sid = tl[start], ch[start], 0
    cand: list[tuple[int, float]] = []  # rejected reads since the last accepted one: (index, innovation)
    a, b = cfg.alpha, cfg.beta
    for i in range(start + 1, len(pl)):
        dt = tl[i] - t_last
        if dt > cfg.max_gap_s:
            out.reason = (f'phase lock lost: {1e3 * dt:.0f} ms without a usable read '
                          f'(> {1e3 * cfg.max_gap_s:.0f} ms)')
            return out
        c, rc = ch[i], rho[i]
        known = c in off
        pred = u + v * dt
        pc = rc * pred + off.get(c, 0.0)
        r = _wrap_c(pl[i] - pc, p, half)
        if known:
            out.inn.append(r)
        if known and abs(r) <= g:
            if c != cur:                 # back on a channel read earlier in this MOVE
                sid, cur = sid + 1, c
            cand = []
            un[i], acc[i], seg[i] = pc + r, True, sid
            u = pred + a * r / rc
            if dtn > 0:
                v += b * r / rc / dtn
            t_last = tl[i]
            continue
        cand.append((i, r))
        need = cfg.relock_reads if known else cfg.channel_lock_reads
        agree = cand[-need:] if need else []
        if need and len(agree) == need and all(ch[j] == c and abs(_wrap_c(rj - r, p, half)) <= 0.5 * g
                                               for j, rj in agree):
            delta = r + sum(_wrap_c(rj - r, p, half) for _, rj in agree) / len(agree)
            if not known or cfg.step_bridge == 'join' or c != cur:
                off[c] = off.get(c, 0.0) + delta      # a new channel, or a step taken as an offset
                sid, cur = sid + 1, c
            else:
                u += delta / rc                      # 'wrapped': the curve crosses the step by δ
            out.relocks += int(known)
            for j, _ in agree:
                pj = rho[j] * (u + v * (tl[j] - t_last)) + off[c]
                un[j], acc[j], seg[j] = pj + _wrap_c(pl[j] - pj, p, half), True, sid
            pred = u + v * (tl[i] - t_last)
            u = pred + a * _wrap_c(pl[i] - (rc * pred + off[c]), p, half) / rc
            t_last, cand = tl[i], []
            continue
        if len(cand) > cfg.max_consecutive_outliers + cfg.relock_reads:
            out.reason = (f'phase lock lost: more than {cfg.max_consecutive_outliers + cfg.relock_reads} '
                          'outliers in a row')
            return out
    return out


def _t_ppf(q: float, nu: np.ndarray) -> np.ndarray:
    from scipy.stats import t as student_t

    return student_t.ppf(q, nu)


_DOF_GRID = np.geomspace(1.0, 60.0, 200)
_MED_ABS = _t_ppf(0.75, _DOF_GRID)                 # median |x| of a unit t_ν
_TAIL_RATIO = _t_ppf(0.95, _DOF_GRID) / _MED_ABS   # 90th percentile / median of |x|: falls with ν


def tail_dof(ratio: float) -> float:
    """ν of the t distribution whose |x| has this 90th-percentile/median ratio (3.58 at ν = 2, 2.44 Gaussian)."""
    return float(np.interp(-ratio, -_TAIL_RATIO, _DOF_GRID))


def t_gate(scale: float, nu: float, outlier_rate: float, period: float) -> float:
    """|r| beyond which a wild read (density ε/P) is likelier than t_ν(scale) noise (density (1 − ε)·f_t)."""
    c = math.exp(math.lgamma(0.5 * (nu + 1.0)) - math.lgamma(0.5 * nu)) / math.sqrt(nu * math.pi)
    ratio = c * (1.0 - outlier_rate) * period / (outlier_rate * scale)
    return scale * math.sqrt(nu * max(ratio ** (2.0 / (nu + 1.0)) - 1.0, 0.0))


class PhaseProcessor:
    """The MOVE stream → dφ for one reader over a search: ``process_move`` plus the noise state.

    With ``noise='fixed'`` it is ``process_move`` exactly. With ``noise='online'`` or ``'robust'`` it
    keeps the last ``noise_memory`` MOVEs' noise estimates (module doc); ``noise_std`` is their
    median. ``'robust'`` also keeps those MOVEs' innovations, from which ``tail`` learns the t model
    of the reads and ``gate`` the outlier gate.
    """

    def __init__(self, cfg: UnwrapConfig | None = None) -> None:
        self.cfg = cfg or UnwrapConfig()
        self._samples: deque[float] = deque(maxlen=self.cfg.noise_memory)
        self._inn: deque[np.ndarray] = deque(maxlen=self.cfg.noise_memory)

    @property
    def noise_std(self) -> float:
        return float(np.median(self._samples)) if self._samples else self.cfg.noise_prior

    def tail(self) -> tuple[float, float]:
        """(scale, ν) of the t model of the read innovations over the last MOVEs (module doc)."""
        cfg = self.cfg
        r = np.abs(np.concatenate(self._inn)) if self._inn else np.empty(0)
        if r.size < cfg.min_tail_samples:
            nu = cfg.tail_dof or 2.0
            return cfg.noise_prior * float(np.interp(nu, _DOF_GRID, _MED_ABS)) / 0.6745, nu
        med, q90 = (float(v) for v in np.quantile(r, (0.5, 0.9)))
        nu = cfg.tail_dof or tail_dof(q90 / max(med, 1e-12))
        return max(med, 1e-6) / float(np.interp(nu, _DOF_GRID, _MED_ABS)), nu

    def gate(self) -> float:
        """The outlier gate: ``noise='online'``: gate_sigmas·σ̂; ``'robust'``: ``t_gate`` of ``tail``;
        both within [``min_gate``, ``gate``·P]."""
        cfg = self.cfg
        p = float(cfg.period)
        g = t_gate(*self.tail(), cfg.outlier_rate, p) if cfg.noise == 'robust' else cfg.gate_sigmas * self.noise_std
        return min(cfg.gate * p, max(cfg.min_gate, g))

    def process(self, stream: PhaseStream) -> DphiEstimate:
        return _process(stream, self.cfg, self if self.cfg.noise != 'fixed' else None)

    def _add(self, sample: float) -> None:
        if math.isfinite(sample) and sample > 0.0:
            self._samples.append(sample)


def process_move(stream: PhaseStream, cfg: UnwrapConfig | None = None) -> DphiEstimate:
    """Unwrap, reject outliers, smooth; return the step's dφ (eq. 6 sign) or why there is none.

    Stateless: with ``noise='online'`` it uses ``noise_prior`` as σ̂ (use ``PhaseProcessor`` to learn it).
    """
    cfg = cfg or UnwrapConfig()
    return _process(stream, cfg, PhaseProcessor(cfg) if cfg.noise != 'fixed' else None)


def _process(stream: PhaseStream, cfg: UnwrapConfig, noise: PhaseProcessor | None) -> DphiEstimate:
    bad = _precheck(stream, cfg)
    if bad is not None:
        return bad
    n, t = len(stream), stream.t
    p = float(cfg.period)
    g = cfg.gate * p
    if noise is not None:
        g = noise.gate()
    tl, pl = t.tolist(), stream.phase.tolist()
    if stream.carrier_hz is None:
        rho, ch = [1.0] * n, [0.0] * n
    else:
        rho, ch = (stream.carrier_hz / cfg.carrier_hz).tolist(), stream.carrier_hz.tolist()
    start, v = _lock(tl, pl, ch, p, g)
    if start < 0:
        return _fail(StreamStatus.INVALID, 'no three consecutive consistent reads: cannot lock on the phase', n, n)
    dtn = float(np.median(np.diff(t)))          # nominal read interval for the β gain
    tr = _track(tl, pl, rho, ch, start, v, dtn, cfg, g)
    if noise is not None and cfg.noise == 'robust' and tr.inn:
        noise._inn.append(np.asarray(tr.inn))
    unw, acc_a, seg_a = np.array(tr.un), np.array(tr.acc), np.array(tr.seg)
    # segments: runs of accepted reads; drop the short ones (the neighbours' lines bridge them)
    ids = np.unique(seg_a[acc_a])
    if ids.size > 1:
        counts = np.bincount(seg_a[acc_a], minlength=int(ids.max()) + 1)
        short = acc_a & (counts[np.maximum(seg_a, 0)] < cfg.min_segment_reads)
        acc_a = acc_a & ~short
        ids = np.unique(seg_a[acc_a])
    n_out = n - int(acc_a.sum())
    reason = tr.reason
    if not reason and n_out > cfg.max_outlier_fraction * n:
        reason = f'{n_out} of {n} reads are outliers (> {cfg.max_outlier_fraction:.0%})'
    if not reason and ids.size == 0:
        reason = 'no segment long enough to fit'
    if reason:
        return _fail(StreamStatus.INVALID, reason, n, n_out, unw, acc_a, tr.relocks)
    return _combine(stream, cfg, noise, t, unw, acc_a, seg_a, ids, rho, ch, n, n_out, tr.relocks)


def _combine(stream: PhaseStream, cfg: UnwrapConfig, noise: PhaseProcessor | None, t, unw, acc_a, seg_a, ids,
             rho: list, ch: list, n: int, n_out: int, relocks: int) -> DphiEstimate:
    """dφ from the segments: end fits at the boundaries, each segment in range with its own λ (module doc)."""
    segs = [(t[acc_a & (seg_a == k)], unw[acc_a & (seg_a == k)], rho[int(np.flatnonzero(seg_a == k)[0])],
             ch[int(np.flatnonzero(seg_a == k)[0])]) for k in ids]
    sigma = math.nan
    w = cfg.smooth_window
    if noise is not None:
        res = [_fit_residuals(ts[:cfg.smooth_window], us[:cfg.smooth_window]) for ts, us, _, _ in segs]
        res += [_fit_residuals(ts[-cfg.smooth_window:], us[-cfg.smooth_window:]) for ts, us, _, _ in segs
                if ts.size > cfg.smooth_window]
        r = np.concatenate(res)
        if r.size >= 4:
            noise._add(1.4826 * float(np.median(np.abs(r - np.median(r)))))
        sigma = noise.noise_std
        w_noise = math.ceil(4.0 * sigma * sigma / (cfg.end_noise * cfg.end_noise))
        w = int(min(cfg.smooth_window, max(cfg.min_segment_reads, w_noise)))
    # boundaries: the button presses at the ends, the middle of the gap between two segments
    bounds = [segs[0][0][0] if stream.t_start is None else min(segs[0][0][0], stream.t_start)]
    bounds += [0.5 * (segs[k][0][-1] + segs[k + 1][0][0]) for k in range(len(segs) - 1)]
    bounds.append(segs[-1][0][-1] if stream.t_end is None else max(segs[-1][0][-1], stream.t_end))
    total, var = 0.0, 0.0
    for k, (ts, us, rk, _) in enumerate(segs):
        wk = min(w, ts.size)
        first = _end_value(ts[:wk], us[:wk], bounds[k])
        last = _end_value(ts[-wk:], us[-wk:], bounds[k + 1])
        total += (last - first) / rk
        if noise is not None and cfg.noise == 'robust':      # each end with its own spread, at least σ̂
            for te, ue, at in ((ts[:wk], us[:wk], bounds[k]), (ts[-wk:], us[-wk:], bounds[k + 1])):
                se = max(sigma, _end_spread(te, ue)) if math.isfinite(_end_spread(te, ue)) else sigma
                var += se * se * _end_var_factor(te, ue, at) / (rk * rk)
        elif noise is not None:
            var += (_end_var_factor(ts[:wk], us[:wk], bounds[k])
                    + _end_var_factor(ts[-wk:], us[-wk:], bounds[k + 1])) / (rk * rk)
    hops = sum(int(segs[k][3] != segs[k + 1][3]) for k in range(len(segs) - 1))
    if noise is None:
        dphi_std = math.nan
    elif cfg.noise == 'robust':          # re-locks bridged 'wrapped': an unknown offset, uniform over P each
        step_var = relocks * cfg.period * cfg.period / 12.0 if cfg.step_bridge == 'wrapped' else 0.0
        dphi_std = math.sqrt(cfg.dphi_std_factor ** 2 * var + step_var)
    else:
        dphi_std = sigma * math.sqrt(var)
    return DphiEstimate(StreamStatus.OK, cfg.sign * total, '', n, n_out, unw, acc_a, relocks, hops,
                        dphi_std, sigma)


def naive_unwrap(phase: np.ndarray, period: float) -> np.ndarray:
    """Textbook unwrap (each wrapped difference to (−P/2, P/2], cumulated): the baseline of the tests."""
    ph = np.asarray(phase, dtype=float)
    d = np.diff(ph)
    d = 0.5 * period - np.mod(0.5 * period - d, period)
    return np.concatenate([ph[:1], ph[0] + np.cumsum(d)])


def naive_dphi(stream: PhaseStream, cfg: UnwrapConfig) -> float:
    """The naive baseline's dφ: ``naive_unwrap`` of all reads, last minus first, in eq. 6's sign (NaN: < 2 reads).

    It ignores carriers (one curve across hops, in the reference units), as ``np.unwrap`` on a reader's log would.
    """
    if len(stream) < 2:
        return math.nan
    u = naive_unwrap(stream.phase, cfg.period)
    return cfg.sign * float(u[-1] - u[0])
