"""Track-to-track association of every pair of tracks: what the ``fusion`` node computes, without ROS.

``PairAssociator`` keeps the latest report per track (``TrackTable``) and the source of each track.
``score(t)`` brings every live track to ``t``, enumerates the pairs i < j of the table's order,
masks the pairs of one source (a source does not report a ship twice) unless ``same_source_pairs``,
scores them in one batch (geofeasibility, paper eqs. 49–71; ``mc`` shares one draw among the pairs
of an instant), adds the clipped instant score to the pair's window of the last ``window`` instants,
combines the window (harmonic or geometric mean, §1), associates the pair when the combination is ≥
``threshold`` and fuses each associated pair by covariance intersection (their correlation is
unknown).

- ``gate=True`` (``exact``): only pairs whose 2σ ellipses may overlap are scored
  (``geofeasibility.gate``), the others are exactly 0; ``Instant.pairs`` holds the candidates,
  ``Instant.all_pairs()`` every pair. A tick costs O(n log n + candidates) instead of O(n²).
- ``floor`` ε > 0: a disjoint instant enters the mean as ε instead of vetoing the window.
- ``release_ratio`` ρ < 1: an associated pair stays so while its combination is ≥ ρ·``threshold``
  (``release_ratio_of``: ρ = ε^(1/K), or ε^(1/(K + ν)) with a prior).
- ``prior_weight`` ν > 0, ``prior_score`` s̄: the window's combination includes ν instants of s̄.
- Defaults (ε = 0, ρ = 1, ν = 0) are the paper's rule, bit for bit.
- A failing batch is scored pair by pair; a pair that raises or is not finite is skipped
  (``Instant.skipped``, window untouched).
- ``stamp_rate``: instants of the data (``StampSchedule``): ``push`` returns the instants it made
  due; without it the caller scores at its own ticks. In full: docs/MODULES.md, "The pair
  associator".
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from track_core.filters.covariance_intersection import covariance_intersection
from track_core.fusion.config import AssociatorConfig
from track_core.fusion.liveness import LiveIntervals
from track_core.fusion.schedule import StampSchedule
from track_core.fusion.tracks import TrackReport, TrackTable
from track_core.geofeasibility import PairWindows, check_pairs, score
from track_core.geofeasibility.gate import GATED_METHODS, candidate_pairs
from track_core.geofeasibility.track import with_prior

_POSITIONAL = ('method', 'threshold', 'combine', 'window')   # PairAssociator's positional settings
LIVE = ('threshold', 'release_ratio', 'prior_weight', 'prior_score', 'stale_after', 'max_prediction')
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
    """The pair associator of ``config`` (``AssociatorConfig``; module docstring). ``fields`` override the
    config's fields by name (the first four may be positional: method, threshold, combine, window);
    ``stamp_streams``: the input streams whose watermarks the stamp schedule waits for."""

    def __init__(self, *args, config: AssociatorConfig | None = None, stamp_streams: tuple[str, ...] = (),
                 **fields) -> None:
        if args and isinstance(args[0], AssociatorConfig):
            config, args = args[0], args[1:]
        if len(args) > len(_POSITIONAL):
            raise TypeError(f'PairAssociator takes at most {len(_POSITIONAL)} positional settings, got {len(args)}')
        config = config or AssociatorConfig()
        if args or fields:
            config = dataclasses.replace(config, **dict(zip(_POSITIONAL, args, strict=False)), **fields)
        self.config = c = config
        self.method, self.combine, self.window = c.method, c.combine, int(c.window)
        self.floor = float(c.floor)
        self.table = TrackTable(c.stale_after, c.max_prediction, c.q_s)
        self.tune(c)
        self.n_samples, self.same_source_pairs = c.n_samples, c.same_source_pairs
        self.rng = np.random.default_rng(c.seed)
        self.gate = c.gate and c.method in GATED_METHODS
        self.schedule = (StampSchedule(c.stamp_rate, streams=stamp_streams, max_wait=c.stamp_max_wait)
                         if c.stamp_rate is not None else None)
        self._clear()

    def tune(self, config: AssociatorConfig) -> None:
        """Take the settings of ``config`` that may change between instants (the node's live parameters:
        ``threshold``, ``release_ratio``, the prior, ``stale_after``, ``max_prediction``)."""
        self.threshold, self.release_ratio = float(config.threshold), float(config.release_ratio)
        self.prior_weight, self.prior_score = float(config.prior_weight), float(config.prior_score)
        self.table.stale_after, self.table.max_prediction = config.stale_after, config.max_prediction
        self.config = dataclasses.replace(self.config, **{k: getattr(config, k) for k in LIVE})

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
