"""Track-to-track association of every pair of tracks: what the ``fusion`` node computes, without ROS.

``PairAssociator`` keeps the latest report per track (``TrackTable``) and the source of each
track. ``score(t)`` brings every live track to ``t``, enumerates the pairs i < j of the table's
order, masks the pairs of one source (a source does not report a ship twice) unless
``same_source_pairs``, scores them in one batch (geofeasibility, paper eqs. 49–71; ``mc`` shares
one draw among the pairs of an instant), adds the clipped instant score to the pair's window of
the last ``window`` instants, combines the window (harmonic or geometric mean, §1), associates
the pair when the combination is ≥ ``threshold`` and fuses each associated pair by covariance
intersection (their correlation is unknown).

Candidates (``gate=True``, method ``exact``): only the pairs whose 2σ ellipses may overlap are
scored (``track_core.geofeasibility.gate``: cKDTree radius gate and separating-ellipse test), with
integer source codes masking the same-source ones; every other pair scores exactly 0 there (the
exact score of disjoint ellipses), so nothing is computed or stored for it. ``Instant.pairs`` holds
the candidates; ``Instant.all_pairs()`` lists every pair with the candidates' values and 0 for the
others, equal to scoring every pair (tests compare them with the node's old path). A pair's window
holds its last min(n, ``window``) instant scores, n being the instants at which both of its tracks
were live (``liveness.LiveIntervals``, nothing stored per pair); ``PairWindows`` keeps the runs of
the pairs whose newest score is positive, and a stored run broken by a non-candidate instant is
dropped at that instant. A tick costs O(n log n + candidates) instead of O(n²). The other methods
score every pair of different sources (their score is not 0 outside the gate).

Floor (``floor`` ε > 0, ``geofeasibility.track``: a disjoint instant enters the mean as ε instead of
vetoing the window): a zero no longer breaks a run, so ``PairWindows`` keeps the window of every
pair that was a candidate (positive score) within its last ``window`` instants, and at each instant
those of them that are live but not candidates are added with score 0 (listed in ``Instant.pairs``
with their combination, associated and fused when it stays ≥ ``threshold``). A pair with no positive
score in its window combines to 0 as before, so the cost stays O(n log n + candidates + stored
windows). ``floor`` 0 (the default) is the paper's means, and the code path, bit for bit.

Release (``release_ratio`` ρ < 1: hysteresis, as track management confirms and deletes at two
levels): a pair associated at its previous scored instant stays associated while its combination is
≥ ρ·``threshold``; a pair not associated needs ``threshold``. The paper decides each instant afresh (one
level); with a window of K and a floor ε one disjoint instant lowers a combination by the factor
ε^(1/K), so ρ = ε^(1/K) (``release_ratio_of``) keeps an association through one such instant and
nothing weaker: without it a pair at the threshold flickers off and on. ρ = 1 (the default) is the
paper's rule, bit for bit. A pair that was not associated is unaffected, so the release never makes
a new association.

Prior (``prior_weight`` ν > 0, ``prior_score`` s̄: ``geofeasibility.track.with_prior``): the
combination of a pair's window of n instants includes ν instants scoring s̄, so a young pair
(n = 1, 2) is not decided on one or two instant scores alone, and the prior's weight fades as the
window fills. The decision and ``combined`` use it. A pair with no positive score in its window
stays at 0. One disjoint instant then lowers a combination by ε^(1/(K + ν)), and
``release_ratio_of(floor, window, prior_weight)`` gives that ratio. ν = 0 (the default) is the paper's
combination, bit for bit.

Isolation: when the batch fails (a degenerate covariance slipped past the caller's checks), each
pair is scored alone; a pair whose score raises (or comes out not finite) is skipped and reported in
``Instant.skipped`` (ids and reason, its window untouched) and every other pair is scored as
usual. Valid input never takes that path, so its results (and the ``mc`` draws) are unchanged.

With ``stamp_rate`` the instants are those of the data (``StampSchedule``): ``push`` queues a
report and returns the instants it made due, each scored with the reports stamped up to it.
Without it ``push`` applies the report at once and the caller scores at its own ticks.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from track_core.filters.covariance_intersection import covariance_intersection
from track_core.fusion.liveness import LiveIntervals
from track_core.fusion.schedule import StampSchedule
from track_core.fusion.tracks import TrackReport, TrackTable
from track_core.geofeasibility import PairWindows, ScoreWindow, check_pairs, score
from track_core.geofeasibility.gate import GATED_METHODS, candidate_pairs
from track_core.geofeasibility.track import THRESHOLD, check_prior, with_prior

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

    def subset(self, mask) -> PairScores:
        """The pairs where ``mask`` holds, as columns."""
        k = np.flatnonzero(mask)
        return PairScores(self.ids, self.ia[k], self.ib[k], self.score[k], self.combined[k], self.instants[k],
                          self.associated[k])

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
    """Everything scored at ``t``: the live tracks (ids, μ, R), the scored pairs, the pairs ``skipped`` (a, b, reason).

    ``pairs`` are the pairs scored (with the gate: the candidates); ``all_pairs()`` adds every other
    pair of different sources, which scored 0 (built on demand: O(n²) for n tracks).
    """

    t: float
    ids: list[str]
    mu: np.ndarray
    R: np.ndarray
    pairs: Sequence[PairScore] = ()
    fused: tuple[FusedPair, ...] = ()
    error: str | None = None
    skipped: tuple[tuple[str, str, str], ...] = ()
    every: Callable[[], PairScores] | None = field(default=None, repr=False, compare=False)

    def all_pairs(self) -> Sequence[PairScore]:
        """Every pair of the instant (i < j in ``ids`` order): the scored ones and the zero-score rest."""
        return self.pairs if self.every is None else self.every()


class PairAssociator:
    def __init__(self, method: str = 'exact', threshold: float = THRESHOLD, combine: str = 'geometric',
                 window: int = 10, *, n_samples: int = 500, same_source_pairs: bool = False,
                 stale_after: float = 2.0, max_prediction: float = 10.0, q_s: float = 0.0, seed: int = 0,
                 stamp_rate: float | None = None, stamp_streams: tuple[str, ...] = (),
                 stamp_max_wait: float = float('inf'), gate: bool = True, floor: float = 0.0,
                 release_ratio: float = 1.0, prior_weight: float = 0.0, prior_score: float = 1.0) -> None:
        if method not in METHODS:
            raise ValueError(f'method must be one of {", ".join(METHODS)}, got {method!r}')
        if not 0.0 <= threshold <= 1.0 or window < 1 or not 0.0 < release_ratio <= 1.0:
            raise ValueError(f'need 0 <= threshold <= 1, 0 < release_ratio <= 1 and window >= 1; got {threshold}, '
                             f'{release_ratio}, {window}')
        ScoreWindow(combine, floor=floor)  # checks the combination's name and the floor
        self.prior_weight, self.prior_score = check_prior(prior_weight, prior_score)
        self.method, self.threshold, self.combine, self.window = method, threshold, combine, int(window)
        self.floor, self.release_ratio = float(floor), float(release_ratio)
        self.n_samples, self.same_source_pairs = n_samples, same_source_pairs
        self.rng = np.random.default_rng(seed)
        self.table = TrackTable(stale_after, max_prediction, q_s)
        self.gate = gate and method in GATED_METHODS
        self.schedule = (StampSchedule(stamp_rate, streams=stamp_streams, max_wait=stamp_max_wait)
                         if stamp_rate is not None else None)
        self._clear()

    def _clear(self) -> None:
        self.source: dict[str, str] = {}
        self.windows = PairWindows(self.combine, self.window, self.floor)
        self.live = LiveIntervals()
        self._slot: dict[str, int] = {}      # track id → permanent integer (pair keys, liveness)
        self._names: list[str] = []
        self._codes: dict[str, int] = {}     # source → integer code
        self._src: list[int] = []            # source code per slot
        self._skips: dict[int, list[int]] = {}   # pair key → instants at which its score failed
        self._last_t: float | None = None
        self._held = np.zeros(0, np.int64)   # keys of the pairs associated at their last scored instant

    def reset(self) -> None:
        """Forget every track, pair window and scheduled instant (the clock jumped: their times are over)."""
        self.table = TrackTable(self.table.stale_after, self.table.max_prediction, self.table.q_s)
        self._clear()
        if self.schedule is not None:
            sc = self.schedule
            self.schedule = StampSchedule(sc.rate, sc.max_skip, sc.streams, sc.max_wait)

    def update(self, source: str, track_id: str, report: TrackReport | None) -> None:
        """Make ``report`` the latest of ``track_id`` (a track of ``source``); None forgets the track."""
        if report is None:
            self.forget(track_id)
            return
        self.source[track_id] = source
        code = self._codes.setdefault(source, len(self._codes))
        slot = self._slot.get(track_id)
        if slot is None:
            self._slot[track_id] = len(self._names)
            self._names.append(track_id)
            self._src.append(code)
        else:
            self._src[slot] = code
        self.table.update(track_id, report)

    def forget(self, track_id: str) -> None:
        """Drop a track and its pairs' windows: if it comes back, it is a new track (a shard's track that left)."""
        slot = self._slot.pop(track_id, None)
        if slot is None:
            return
        self.table.latest.pop(track_id, None)
        self.source.pop(track_id, None)
        a, b = np.divmod(self.windows.keys, _STRIDE)
        self.windows.drop((a == slot) | (b == slot))
        a, b = np.divmod(self._held, _STRIDE)
        self._held = self._held[(a != slot) & (b != slot)]

    def push(self, source: str, track_id: str, report: TrackReport, t: float | None = None,
             stream: str | None = None) -> list[Instant]:
        """Take one report (None: forget the track at stamp ``t``) from input ``stream`` (the schedule's
        watermarks, ``StampSchedule``); return the instants it made due that had a pair."""
        if self.schedule is None:
            self.update(source, track_id, report)
            return []
        stamp = report.t if report is not None else float(t)
        return self._score_due(self.schedule.push(stamp, track_id, (source, track_id, report), stream))

    def heard(self, stream: str, t: float) -> list[Instant]:
        """Input ``stream`` delivered stamp ``t`` with no report to push (a shard's input of tracks held
        elsewhere): its watermark moves on; → the instants that made due."""
        return [] if self.schedule is None else self._score_due(self.schedule.heard(stream, t))

    def _score_due(self, due: list) -> list[Instant]:
        out = []
        for t_k, released in due:
            for item in released:
                self.update(*item)
            instant = self.score(t_k)
            if instant is not None:
                out.append(instant)
        return out

    def pairs_at(self, ids: list[str]) -> tuple[np.ndarray, np.ndarray]:
        """Rows (i, j), i < j, of every pair to score among ``ids`` (different sources unless ``same_source_pairs``)."""
        return self._pairs_of(self._src_of(self._slots(ids)))

    def _slots(self, ids: list[str]) -> np.ndarray:
        return np.fromiter((self._slot[k] for k in ids), np.int64, len(ids))

    def _src_of(self, slots: np.ndarray) -> np.ndarray:
        return np.asarray(self._src, np.int64)[slots]

    def _pairs_of(self, src: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        i, j = np.triu_indices(src.size, 1)
        if not self.same_source_pairs:
            keep = src[i] != src[j]
            i, j = i[keep], j[keep]
        return i, j

    @property
    def history(self) -> dict[tuple[str, str], int]:
        """Every pair with a stored run (positive newest score): (a, b) → instants in its window (for tests)."""
        a, b = np.divmod(self.windows.keys, _STRIDE)
        n = np.minimum(self.windows.total, self.window)
        return {(self._names[x], self._names[y]): int(c)
                for x, y, c in zip(a.tolist(), b.tolist(), n.tolist(), strict=True)}

    def score(self, t: float) -> Instant | None:
        """Score the pairs of live tracks at ``t`` (with the gate: the candidates); None when there is no pair."""
        ids, mu, R = self.table.at(t)
        if len(ids) < 2:
            return None
        slots = self._slots(ids)
        src = self._src_of(slots)
        if not self.same_source_pairs and np.all(src == src[0]):
            return None
        if self._last_t is not None and t < self._last_t:
            raise ValueError(f'time went backwards: {t} < {self._last_t}')
        self._last_t = float(t)
        i, j, s, failed, gated = self._candidates(mu, R, src)
        m = self.live.mark(slots)
        keys = slots[i] * _STRIDE + slots[j]
        skipped = tuple((ids[i[k]], ids[j[k]], reason) for k, reason in failed.items())
        ok = np.ones(i.size, bool)
        ok[list(failed)] = False
        for key in keys[~ok].tolist():
            self._skips.setdefault(key, []).append(m)
        untouched = keys[~ok]          # a failed pair's window is untouched
        i, j, s, keys = i[ok], j[ok], s[ok], keys[ok]
        if self.floor > 0.0:   # the stored windows of live pairs that are not candidates now: score 0
            i, j, s, keys = self._stored_pairs(slots, i, j, s, keys, untouched)
        total = self.live.colive(slots[i], slots[j], m) - self._skipped(keys, m)
        combined, instants = self.windows.add(keys, np.clip(s, 0.0, 1.0), t, total)
        combined = with_prior(combined, instants, self.combine, self.prior_weight, self.prior_score)
        self._drop_broken_runs(np.concatenate([keys, untouched]), m)
        associated = self._associate(keys, combined, untouched)
        a, b = i[associated], j[associated]
        fused = []
        if a.size:
            x, y = _oriented(mu, a, b)
            mu_f, P_f, _ = covariance_intersection(mu[x], R[x], mu[y], R[y])   # batched over the associated pairs
            fused = [FusedPair(ids[x], ids[y], mu_f[k], P_f[k])
                     for k, (x, y) in enumerate(zip(a.tolist(), b.tolist(), strict=True))]
        pairs = PairScores(ids, i, j, s, combined, instants, associated)
        every = (lambda: self._every_pair(ids, slots, src, m, pairs, keys)) if gated else None
        return Instant(t, ids, mu, R, pairs, tuple(fused), skipped=skipped, every=every)

    def _associate(self, keys: np.ndarray, combined: np.ndarray, untouched: np.ndarray) -> np.ndarray:
        """Which pairs ``keys`` are associated at this instant (threshold, and the release of the pairs
        held: module docstring); a pair whose score failed keeps its state."""
        associated = combined >= self.threshold
        level = self.release_ratio * self.threshold
        if self._held.size and self.release_ratio < 1.0:
            associated |= np.isin(keys, self._held) & (combined >= level) & (combined > 0.0)
        self._held = np.concatenate([keys[associated], untouched[np.isin(untouched, self._held)]])
        return associated

    def _stored_pairs(self, slots, i, j, s, keys, untouched):
        """(i, j, s, keys) with every stored window whose two tracks are rows of this instant and that is
        not scored (nor failed) here appended with score 0 (module docstring: floor)."""
        stored = self.windows.keys
        if not stored.size:
            return i, j, s, keys
        stored = stored[~np.isin(stored, np.concatenate([keys, untouched]))]
        a, b = np.divmod(stored, _STRIDE)
        order = np.argsort(slots, kind='stable')
        ra = np.minimum(np.searchsorted(slots[order], a), slots.size - 1)
        rb = np.minimum(np.searchsorted(slots[order], b), slots.size - 1)
        here = (slots[order][ra] == a) & (slots[order][rb] == b)
        ra, rb, stored = order[ra[here]], order[rb[here]], stored[here]
        xi, xj = np.minimum(ra, rb), np.maximum(ra, rb)
        same = slots[xi] * _STRIDE + slots[xj] == stored      # the key orientation of the scored pairs
        xi, xj = xi[same], xj[same]
        i, j = np.concatenate([i, xi]), np.concatenate([j, xj])
        order = np.lexsort((j, i))                              # pair order as without the gate
        return (i[order], j[order], np.concatenate([s, np.zeros(xi.size)])[order],
                np.concatenate([keys, stored[same]])[order])

    def _candidates(self, mu, R, src) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict, bool]:
        """Pairs (i, j) to score, their scores, the failures (isolation, see above), and whether gated."""
        if self.gate:
            try:
                check_pairs(mu, R, mu, R)  # every track valid: the gate and the batch cannot fail
            except ValueError:
                pass                       # isolate the bad tracks' pairs on the ungated path
            else:
                i, j = candidate_pairs(mu, R)
                if not self.same_source_pairs:
                    keep = src[i] != src[j]
                    i, j = i[keep], j[keep]
                a, b = _oriented(mu, i, j)
                s = np.atleast_1d(score(mu[a], R[a], mu[b], R[b], self.method)) if i.size else np.zeros(0)
                return i, j, s, _non_finite(s), True
        i, j = self._pairs_of(src)
        s, failed = self._scores(mu, R, i, j)
        return i, j, s, failed, False

    def _skipped(self, keys: np.ndarray, upto: int) -> np.ndarray:
        """Instants ≤ ``upto`` at which the score of pair ``keys[k]`` failed (isolation; usually none)."""
        out = np.zeros(keys.size, np.int64)
        if self._skips:
            for k, key in enumerate(keys.tolist()):
                out[k] = sum(1 for x in self._skips.get(key, ()) if x <= upto)
        return out

    def _drop_broken_runs(self, keys: np.ndarray, m: int) -> None:
        """Drop the stored runs of the pairs live at ``m`` but not among ``keys`` (they scored 0 there)."""
        w = self.windows
        if not w.keys.size:
            return
        a, b = np.divmod(w.keys, _STRIDE)
        src = np.asarray(self._src, np.int64)
        broken = self.live.live_at(a, m) & self.live.live_at(b, m) & ~np.isin(w.keys, keys)
        if not self.same_source_pairs:
            broken &= src[a] != src[b]
        if broken.any():
            w.drop(broken)

    def _every_pair(self, ids, slots, src, m: int, scored: PairScores, scored_keys: np.ndarray) -> PairScores:
        """Every pair at instant ``m``: the scored ones as they are, the others 0 with their window lengths."""
        i, j = self._pairs_of(src)
        keys = slots[i] * _STRIDE + slots[j]
        if self._skips:   # a pair whose score failed at m was not scored there
            failed = np.array([m in self._skips.get(k, ()) for k in keys.tolist()], bool)
            i, j, keys = i[~failed], j[~failed], keys[~failed]
        order = np.argsort(scored_keys)
        pos = np.searchsorted(scored_keys[order], keys)
        pos = np.minimum(pos, max(scored_keys.size - 1, 0))
        hit = scored_keys[order][pos] == keys if scored_keys.size else np.zeros(keys.size, bool)
        k = order[pos] if scored_keys.size else pos
        n = np.minimum(self.live.colive(slots[i], slots[j], m) - self._skipped(keys, m), self.window)
        return PairScores(ids, i, j, np.where(hit, scored.score[k] if len(scored) else 0.0, 0.0),
                          np.where(hit, scored.combined[k] if len(scored) else 0.0, 0.0),
                          np.where(hit, scored.instants[k] if len(scored) else 0, n),
                          hit & (scored.associated[k] if len(scored) else False))

    def _scores(self, mu: np.ndarray, R: np.ndarray, i: np.ndarray, j: np.ndarray) -> tuple[np.ndarray, dict]:
        """Instant scores of every pair (i, j) and the reason per pair that failed (isolation, see above)."""
        a, b = _oriented(mu, i, j) if self.method in GATED_METHODS else (i, j)
        try:
            s = np.atleast_1d(score(mu[a], R[a], mu[b], R[b], self.method, n_samples=self.n_samples,
                                    rng=self.rng, shared_samples=True))
            failed = _non_finite(s)
        except (ValueError, np.linalg.LinAlgError):
            s = np.full(i.size, np.nan)
            failed = self._score_each(mu, R, a, b, s)
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


def release_ratio_of(floor: float, window: int, prior_weight: float = 0.0) -> float:
    """The release ratio that keeps an association through one disjoint instant: ε^(1/(K + ν)) (module
    docstring); 1 (no hysteresis) without a floor."""
    return float(floor ** (1.0 / (window + prior_weight))) if floor > 0.0 else 1.0


def _non_finite(s: np.ndarray) -> dict[int, str]:
    return {int(k): f'scoring failed: non-finite score {s[k]}' for k in np.flatnonzero(~np.isfinite(s))}


def _oriented(mu: np.ndarray, i: np.ndarray, j: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The pairs (i, j) ordered by their tracks' positions (x, then y): the exact score is symmetric, but
    only up to rounding, so a pair scored in one fixed orientation gives the same bits whatever the
    order in which its tracks were first seen (a shard and a single node agree to the last bit)."""
    swap = (mu[i, 0] > mu[j, 0]) | ((mu[i, 0] == mu[j, 0]) & (mu[i, 1] > mu[j, 1]))
    return np.where(swap, j, i), np.where(swap, i, j)
