"""Reader signal processing: one MOVE's stream of wrapped phase reads → the step's dφ (eq. 6).

The reader reads the tag about 300 times a second while the user walks one step (Section II,
Figs. 1–2). ``process_move`` unwraps that stream, rejects outliers, smooths the two ends and
returns dφ = −(φ_end − φ_start) in the sign of eq. 6 (see ``phase``), or a "signal lost" /
"invalid" status with a reason.

Unwrapping and the outlier rule (a sequential gate, pure-Python floats: ~1 µs a read):

1. **Lock.** The first read that agrees with its two successors is the start: both wrapped
   differences |wrap(φ_{i+1} − φ_i)| and |wrap(φ_{i+2} − φ_{i+1})| are ≤ the gate g. Reads before
   it are outliers. wrap(·) maps into (−P/2, P/2] for the reader's wrap period P.
2. **Track.** An α–β tracker (level u, slope v in rad/s, α = 0.3, β = 0.05) predicts each read:
   û = u + v·Δt, and updates u ← û + α r, v ← v + β r / Δt₀ with Δt₀ the median read interval
   (the exponential inter-read times make r/Δt explode for the shortest Δt). The initial slope is
   the median, over the first 20 reads, of wrapped 5-read differences per second. The read's
   innovation is r = wrap(φ − û), taken on the wrapped read's nearest branch.
3. **Outlier rule.** A read is an outlier when |r| > g, with g = ``gate``·P (default 0.15·P: 0.47 rad
   for the (0, π] reader, 0.94 rad for (0, 2π]). Outliers are dropped and do not move the tracker.
   A legitimate read's innovation is its noise (s_θ ≈ 0.1 rad) plus the prediction error. Walking
   at 1 m/s the phase moves 4π/λ·v ≈ 36 rad/s, ≈ 0.12 rad between reads at 300 reads/s, which the
   slope predicts. An outlier that happens to fall inside the gate (a fraction 2g/P = 30 % of
   uniform outliers) moves the level by at most α·g and the slope by β·g/Δt₀; the small β is chosen
   for that.
4. Accepted reads are unwrapped to û + r. This is the branch a naive unwrap would choose, but relative
   to a prediction rather than the previous raw read, so a single wild read cannot shift everything
   after it by ±P (the naive unwrap does so with probability ≈ 2·|Δφ per read|/P per outlier).
5. **Lost lock.** More than ``max_consecutive_outliers`` rejected reads in a row, or an accepted gap
   longer than ``max_gap_s`` (the phase may have moved by more than P/2 unseen), makes the
   unwrapped curve ambiguous. The step is invalid: its dφ is NaN and the reason says why.

Smoothing: lines through the first and the last ``smooth_window`` (20) accepted reads (least squares,
refitted once without the reads more than 3 MAD-σ off, e.g. an outlier that passed the gate),
evaluated at the step's start and end (the button presses, ``t_start``/``t_end``, when given; else
the first and the last accepted read). dφ = −(end − start). Stopping at the reads instead would
miss the few milliseconds before the first read and after the last one: ≈ 0.2 rad at walking speed.
With W = 20 reads (≈ 65 ms) the dφ noise is ≈ 0.6·s_θ instead of √2·s_θ.


Signal lost: no reads at all (tag in the antenna's back lobe or out of range), fewer than
``min_reads``, or reads that do not cover the step (the first read more than ``max_edge_gap_s``
after the step started, or the last one that long before it ended, when those times are given).
An outlier fraction above ``max_outlier_fraction`` is also invalid.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import Enum

import numpy as np


class StreamStatus(Enum):
    OK = 'ok'
    SIGNAL_LOST = 'signal_lost'   # no (or too few, or not covering) reads: back lobe / out of range
    INVALID = 'invalid'           # reads present but the unwrapped curve cannot be trusted


@dataclass(frozen=True)
class PhaseStream:
    """Reads of one action: times (s), wrapped phases (rad), RSSI (dBm), all the same length."""

    t: np.ndarray
    phase: np.ndarray
    rssi: np.ndarray
    t_start: float | None = None   # when the user pressed the button (start of the action)
    t_end: float | None = None     # when the action was confirmed

    def __post_init__(self) -> None:
        for name in ('t', 'phase', 'rssi'):
            object.__setattr__(self, name, np.asarray(getattr(self, name), dtype=float).reshape(-1))
        if not (self.t.size == self.phase.size == self.rssi.size):
            raise ValueError(f'PhaseStream: t, phase, rssi lengths differ ({self.t.size}, {self.phase.size}, '
                             f'{self.rssi.size})')

    def __len__(self) -> int:
        return int(self.t.size)

    @classmethod
    def empty(cls, t_start: float | None = None, t_end: float | None = None) -> PhaseStream:
        z = np.empty(0)
        return cls(z, z, z, t_start, t_end)


@dataclass(frozen=True)
class UnwrapConfig:
    """Parameters of ``process_move``; ``period`` is the reader's wrap period P (π or 2π)."""

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

    def __post_init__(self) -> None:
        if not (0.0 < self.gate < 0.5):
            raise ValueError(f'gate must be in (0, 0.5) of the period (ambiguous beyond P/2), got {self.gate}')
        if self.period <= 0.0:
            raise ValueError(f'period must be > 0, got {self.period}')
        if self.smooth_window < 2 or self.min_reads < 3:
            raise ValueError('smooth_window must be >= 2 and min_reads >= 3')


@dataclass(frozen=True)
class DphiEstimate:
    """Result of processing one MOVE's stream."""

    status: StreamStatus
    dphi: float                       # eq. 6 sign; NaN unless status is OK
    reason: str = ''
    n_reads: int = 0
    n_outliers: int = 0
    unwrapped: np.ndarray = field(default_factory=lambda: np.empty(0))  # per read; NaN for outliers
    accepted: np.ndarray = field(default_factory=lambda: np.empty(0, bool))

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


def _end_value(t: np.ndarray, u: np.ndarray, at: float) -> float:
    """Line through (t, u) at ``at``: least squares, then once more without reads off by > 3 MAD-σ."""
    tm, um, b = _line(t, u)
    res = u - (um + b * (t - tm))
    keep = np.abs(res) <= max(3.0 * 1.4826 * float(np.median(np.abs(res - np.median(res)))), 1e-3)
    if 3 <= keep.sum() < t.size:
        tm, um, b = _line(t[keep], u[keep])
    return um + b * (at - tm)


def _fail(status: StreamStatus, reason: str, n: int, n_out: int = 0, un=None, acc=None) -> DphiEstimate:
    return DphiEstimate(status, math.nan, reason, n, n_out,
                        np.full(n, np.nan) if un is None else un,
                        np.zeros(n, bool) if acc is None else acc)


def _precheck(stream: PhaseStream, cfg: UnwrapConfig) -> DphiEstimate | None:
    """Signal lost or malformed before any unwrapping; None when the stream can be unwrapped."""
    n, t = len(stream), stream.t
    problem = None
    if n == 0:
        problem = (StreamStatus.SIGNAL_LOST, 'signal lost: no reads during the step (tag in the back lobe or out '
                   'of range)')
    elif not (np.all(np.isfinite(t)) and np.all(np.isfinite(stream.phase))):
        problem = (StreamStatus.INVALID, 'non-finite time or phase in the stream')
    elif np.any(np.diff(t) < 0):
        problem = (StreamStatus.INVALID, 'read times are not in order')
    elif n < cfg.min_reads:
        problem = (StreamStatus.SIGNAL_LOST, f'signal lost: only {n} reads (< {cfg.min_reads})')
    elif stream.t_start is not None and t[0] - stream.t_start > cfg.max_edge_gap_s:
        problem = (StreamStatus.SIGNAL_LOST,
                   f'signal lost: first read {1e3 * (t[0] - stream.t_start):.0f} ms after the step started')
    elif stream.t_end is not None and stream.t_end - t[-1] > cfg.max_edge_gap_s:
        problem = (StreamStatus.SIGNAL_LOST,
                   f'signal lost: last read {1e3 * (stream.t_end - t[-1]):.0f} ms before the step ended')
    return None if problem is None else _fail(*problem, n)


def _lock(tl: list, pl: list, p: float, g: float) -> tuple[int, float]:
    """Step 1: the first read agreeing with its two successors, and the initial slope (rad/s)."""
    half = 0.5 * p
    n = len(pl)
    start = next((i for i in range(n - 2) if abs(_wrap_c(pl[i + 1] - pl[i], p, half)) <= g
                  and abs(_wrap_c(pl[i + 2] - pl[i + 1], p, half)) <= g), -1)
    if start < 0:
        return -1, 0.0
    # median over the first reads of wrapped 5-read differences per second (robust to outliers)
    inc = [_wrap_c(pl[i + 5] - pl[i], p, half) / (tl[i + 5] - tl[i])
           for i in range(start, min(n - 5, start + 20)) if tl[i + 5] > tl[i]]
    return start, float(np.median(inc)) if inc else 0.0


def _track(tl: list, pl: list, start: float, v: float, dtn: float, cfg: UnwrapConfig) -> tuple[list, list, str]:
    """Steps 2–5: the α–β tracker with the outlier gate. Returns (unwrapped, accepted, failure reason)."""
    n = len(pl)
    p = float(cfg.period)
    half, g = 0.5 * p, cfg.gate * p
    un, acc = [math.nan] * n, [False] * n
    u = pl[start]
    un[start], acc[start] = u, True
    t_last, run = tl[start], 0
    a, b = cfg.alpha, cfg.beta
    for i in range(start + 1, n):
        dt = tl[i] - t_last
        if dt > cfg.max_gap_s:
            return un, acc, f'phase lock lost: {1e3 * dt:.0f} ms without a usable read (> {1e3 * cfg.max_gap_s:.0f} ms)'
        pred = u + v * dt
        r = _wrap_c(pl[i] - pred, p, half)
        if abs(r) > g:
            run += 1
            if run > cfg.max_consecutive_outliers:
                return un, acc, f'phase lock lost: more than {cfg.max_consecutive_outliers} outliers in a row'
            continue
        run = 0
        un[i], acc[i] = pred + r, True
        u = pred + a * r
        if dtn > 0:
            v += b * r / dtn
        t_last = tl[i]
    return un, acc, ''


def process_move(stream: PhaseStream, cfg: UnwrapConfig | None = None) -> DphiEstimate:
    """Unwrap, reject outliers, smooth; return the step's dφ (eq. 6 sign) or why there is none."""
    cfg = cfg or UnwrapConfig()
    bad = _precheck(stream, cfg)
    if bad is not None:
        return bad
    n, t = len(stream), stream.t
    tl, pl = t.tolist(), stream.phase.tolist()
    start, v = _lock(tl, pl, float(cfg.period), cfg.gate * float(cfg.period))
    if start < 0:
        return _fail(StreamStatus.INVALID, 'no three consecutive consistent reads: cannot lock on the phase', n, n)
    dtn = float(np.median(np.diff(t)))          # nominal read interval for the β gain
    un, acc, reason = _track(tl, pl, start, v, dtn, cfg)
    unw, acc_a = np.array(un), np.array(acc)
    n_out = n - int(acc_a.sum())
    if not reason and n_out > cfg.max_outlier_fraction * n:
        reason = f'{n_out} of {n} reads are outliers (> {cfg.max_outlier_fraction:.0%})'
    if reason:
        return _fail(StreamStatus.INVALID, reason, n, n_out, unw, acc_a)
    ta, ua = t[acc_a], unw[acc_a]
    w = min(cfg.smooth_window, ta.size)
    t_first = ta[0] if stream.t_start is None else min(ta[0], stream.t_start)
    t_end = ta[-1] if stream.t_end is None else max(ta[-1], stream.t_end)
    first = _end_value(ta[:w], ua[:w], t_first)
    last = _end_value(ta[-w:], ua[-w:], t_end)
    return DphiEstimate(StreamStatus.OK, -(last - first), '', n, n_out, unw, acc_a)


def naive_unwrap(phase: np.ndarray, period: float) -> np.ndarray:
    """Textbook unwrap (each wrapped difference to (−P/2, P/2], cumulated): the baseline of the tests."""
    ph = np.asarray(phase, dtype=float)
    d = np.diff(ph)
    d = 0.5 * period - np.mod(0.5 * period - d, period)
    return np.concatenate([ph[:1], ph[0] + np.cumsum(d)])
