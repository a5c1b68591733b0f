"""Track-to-track association of every pair of tracks: what the ``fusion`` node computes, without ROS.

``PairAssociator`` keeps the latest report per track (``TrackTable``) and the source of each
track. ``score(t)`` brings every live track to ``t``, enumerates the pairs i < j of the table's
order, masks the pairs of one source (a source does not report a ship twice) unless
``same_source_pairs``, scores them in one batch (geofeasibility, paper eqs. 49–71; ``mc`` shares
one draw among the pairs of an instant), adds the clipped instant score to the pair's window of
the last ``window`` instants, combines the window (harmonic or geometric mean, §1), associates
the pair when the combination is ≥ ``threshold`` and fuses each associated pair by covariance
intersection (their correlation is unknown).

Gate (``gate=True``, method ``exact``): only the pairs whose 2σ ellipses may overlap are scored
(``track_core.geofeasibility.gate``: cKDTree radius gate and separating-ellipse test); every other
pair gets the exact score's value for disjoint ellipses, 0, so the instant scores equal scoring
every pair (tests compare the two). The windows are one ``PairWindows`` for all pairs (what one
``ScoreWindow`` per pair gives, vectorised: a pair's window still gets its 0 instants), and
``Instant.pairs`` is a ``PairScores`` sequence over column arrays, so an instant of 1000 tracks
(about 250,000 pairs) costs no Python object per pair until one is read.

Isolation: when the batch fails (a degenerate covariance slipped past the caller's checks), each
pair is scored alone; a pair whose score raises (or comes out not finite) is skipped and reported in
``Instant.skipped`` (ids and reason, its window untouched) and every other pair is scored as
usual. Valid input never takes that path, so its results (and the ``mc`` draws) are unchanged.

With ``stamp_rate`` the instants are those of the data (``StampSchedule``): ``push`` queues a
report and returns the instants it made due, each scored with the reports stamped up to it.
Without it ``push`` applies the report at once and the caller scores at its own ticks.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from track_core.filters.covariance_intersection import covariance_intersection
from track_core.fusion.schedule import StampSchedule
from track_core.fusion.tracks import TrackReport, TrackTable
from track_core.geofeasibility import PairWindows, ScoreWindow, check_pairs, gated_score, score
from track_core.geofeasibility.gate import GATED_METHODS
from track_core.geofeasibility.track import THRESHOLD

METHODS = ('exact', 'glr', 'glr_thresholded', 'mc')
_STRIDE = np.int64(1) << 31   # pair key = slot(a) · 2³¹ + slot(b)


@dataclass(frozen=True)
class PairScore:
    """One pair at one instant: ``a``/``b`` are track ids, ``ia``/``ib`` their rows in ``Instant.ids``."""

    a: str
    b: str
    ia: int
    ib: int
    score: float  # the instant score as the method returned it (the window holds it clipped to [0, 1])
    combined: float
    instants: int  # instants in the pair's window
    associated: bool


class PairScores(Sequence):
    """The pairs of one instant as columns; item k is the ``PairScore`` of pair k (built when read).

    Columns: ``ia``, ``ib`` (rows in ``ids``), ``score``, ``combined``, ``instants``, ``associated``.
    """

    def __init__(self, ids: list[str], ia, ib, score, combined, instants, associated) -> None:
        self.ids = ids
        self.ia, self.ib = np.asarray(ia, np.intp), np.asarray(ib, np.intp)
        self.score, self.combined = np.asarray(score, float), np.asarray(combined, float)
        self.instants, self.associated = np.asarray(instants, np.int64), np.asarray(associated, bool)

    def __len__(self) -> int:
        return self.ia.size

    def __getitem__(self, k):
        if isinstance(k, slice):
            return [self[x] for x in range(*k.indices(len(self)))]
        a, b = int(self.ia[k]), int(self.ib[k])
        return PairScore(self.ids[a], self.ids[b], a, b, float(self.score[k]), float(self.combined[k]),
                         int(self.instants[k]), bool(self.associated[k]))

    def select(self, mask) -> list[PairScore]:
        """The ``PairScore`` of the pairs where ``mask`` (a boolean column expression) holds."""
        return [self[int(k)] for k in np.flatnonzero(mask)]

    def nonzero(self) -> list[PairScore]:
        """The pairs with a positive instant or combined score, or associated (the others score 0 throughout)."""
        return self.select((self.score > 0) | (self.combined > 0) | self.associated)


@dataclass(frozen=True)
class FusedPair:
    """Covariance intersection of an associated pair: position ``mu`` (2,), covariance ``P`` (2, 2)."""

    a: str
    b: str
    mu: np.ndarray
    P: np.ndarray


@dataclass(frozen=True)
class Instant:
    """Everything scored at ``t``: the live tracks (ids, μ, R), the pairs, and the pairs ``skipped`` (a, b, reason)."""

    t: float
    ids: list[str]
    mu: np.ndarray
    R: np.ndarray
    pairs: Sequence[PairScore] = ()
    fused: tuple[FusedPair, ...] = ()
    error: str | None = None
    skipped: tuple[tuple[str, str, str], ...] = ()


class PairAssociator:
    def __init__(self, method: str = 'exact', threshold: float = THRESHOLD, combine: str = 'geometric',
                 window: int = 10, *, n_samples: int = 500, same_source_pairs: bool = False,
                 stale_after: float = 2.0, max_prediction: float = 10.0, q_s: float = 0.0, seed: int = 0,
                 stamp_rate: float | None = None, gate: bool = True) -> None:
        if method not in METHODS:
            raise ValueError(f'method must be one of {", ".join(METHODS)}, got {method!r}')
        if not 0.0 <= threshold <= 1.0 or window < 1:
            raise ValueError(f'need 0 <= threshold <= 1 and window >= 1; got {threshold}, {window}')
        ScoreWindow(combine)  # checks the combination's name
        self.method, self.threshold, self.combine, self.window = method, threshold, combine, int(window)
        self.n_samples, self.same_source_pairs = n_samples, same_source_pairs
        self.rng = np.random.default_rng(seed)
        self.table = TrackTable(stale_after, max_prediction, q_s)
        self.source: dict[str, str] = {}
        self.gate = gate and method in GATED_METHODS
        self.windows = PairWindows(combine, self.window)
        self._slot: dict[str, int] = {}   # track id → permanent integer (pair keys)
        self._names: list[str] = []
        self.schedule = StampSchedule(stamp_rate) if stamp_rate is not None else None

    def reset(self) -> None:
        """Forget every track, pair window and scheduled instant (the clock jumped: their times are over)."""
        self.table = TrackTable(self.table.stale_after, self.table.max_prediction, self.table.q_s)
        self.source.clear()
        self.windows = PairWindows(self.combine, self.window)
        self._slot.clear()
        self._names.clear()
        if self.schedule is not None:
            self.schedule = StampSchedule(self.schedule.rate, self.schedule.max_skip)

    def update(self, source: str, track_id: str, report: TrackReport) -> None:
        """Make ``report`` the latest of ``track_id`` (a track of ``source``)."""
        self.source[track_id] = source
        self.table.update(track_id, report)

    def push(self, source: str, track_id: str, report: TrackReport) -> list[Instant]:
        """Take one report; return the instants it made due (stamp schedule) that had a pair to score."""
        if self.schedule is None:
            self.update(source, track_id, report)
            return []
        out = []
        for t_k, released in self.schedule.push(report.t, track_id, (source, track_id, report)):
            for item in released:
                self.update(*item)
            instant = self.score(t_k)
            if instant is not None:
                out.append(instant)
        return out

    def pairs_at(self, ids: list[str]) -> tuple[np.ndarray, np.ndarray]:
        """Rows (i, j), i < j, of the pairs to score among ``ids``."""
        i, j = np.triu_indices(len(ids), 1)
        if not self.same_source_pairs:
            src = np.array([self.source[k] for k in ids])
            keep = src[i] != src[j]
            i, j = i[keep], j[keep]
        return i, j

    @property
    def history(self) -> dict[tuple[str, str], int]:
        """Every pair with a window: (a, b) → instants in it (built on demand; for tests and diagnostics)."""
        a, b = np.divmod(self.windows.keys, _STRIDE)
        return {(self._names[x], self._names[y]): int(c)
                for x, y, c in zip(a.tolist(), b.tolist(), self.windows.count.tolist(), strict=True)}

    def score(self, t: float) -> Instant | None:
        """Score every pair of live tracks at ``t``; None when there is no pair to score."""
        ids, mu, R = self.table.at(t)
        if len(ids) < 2:
            return None
        i, j = self.pairs_at(ids)
        if i.size == 0:
            return None
        s, failed = self._scores(mu, R, i, j)
        skipped = tuple((ids[i[k]], ids[j[k]], reason) for k, reason in failed.items())
        ok = np.ones(i.size, bool)
        ok[list(failed)] = False
        i, j, s = i[ok], j[ok], s[ok]
        slots = np.array([self._slot_of(k) for k in ids], np.int64)
        combined, instants = self.windows.add(slots[i] * _STRIDE + slots[j], np.clip(s, 0.0, 1.0), t)
        associated = combined >= self.threshold
        a, b = i[associated], j[associated]
        fused = []
        if a.size:
            m, P, _ = covariance_intersection(mu[a], R[a], mu[b], R[b])   # batched over the associated pairs
            fused = [FusedPair(ids[x], ids[y], m[k], P[k])
                     for k, (x, y) in enumerate(zip(a.tolist(), b.tolist(), strict=True))]
        pairs = PairScores(ids, i, j, s, combined, instants, associated)
        return Instant(t, ids, mu, R, pairs, tuple(fused), skipped=skipped)

    def _slot_of(self, track_id: str) -> int:
        slot = self._slot.get(track_id)
        if slot is None:
            slot = self._slot[track_id] = len(self._names)
            self._names.append(track_id)
        return slot

    def _scores(self, mu: np.ndarray, R: np.ndarray, i: np.ndarray, j: np.ndarray) -> tuple[np.ndarray, dict]:
        """Instant scores of the pairs (i, j) and the reason per pair that failed (isolation, see above)."""
        if self.gate:
            try:
                check_pairs(mu, R, mu, R)  # every track valid: the gate and the batch cannot fail
            except ValueError:
                pass                       # isolate the bad tracks' pairs on the ungated path
            else:
                s = gated_score(mu, R, i, j, self.method)[0]
                return s, {int(k): f'scoring failed: non-finite score {s[k]}' for k in np.flatnonzero(~np.isfinite(s))}
        try:
            s = np.atleast_1d(score(mu[i], R[i], mu[j], R[j], self.method, n_samples=self.n_samples,
                                    rng=self.rng, shared_samples=True))
            failed = {int(k): f'scoring failed: non-finite score {s[k]}' for k in np.flatnonzero(~np.isfinite(s))}
        except (ValueError, np.linalg.LinAlgError):
            s = np.full(i.size, np.nan)
            failed = self._score_each(mu, R, i, j, s)
        return s, failed

    def _score_each(self, mu: np.ndarray, R: np.ndarray, i: np.ndarray, j: np.ndarray,
                    s: np.ndarray) -> dict[int, str]:
        """Score pair k = (i[k], j[k]) alone into ``s[k]``; → the reason per pair that failed."""
        failed = {}
        for k in range(i.size):
            try:
                v = float(np.atleast_1d(score(mu[i[k]][None], R[i[k]][None], mu[j[k]][None], R[j[k]][None],
                                              self.method, n_samples=self.n_samples, rng=self.rng,
                                              shared_samples=True))[0])
            except (ValueError, np.linalg.LinAlgError) as exc:
                failed[k] = f'scoring failed: {exc}'
                continue
            s[k] = v
            if not np.isfinite(v):
                failed[k] = f'scoring failed: non-finite score {v}'
        return failed
