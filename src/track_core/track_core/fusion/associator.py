"""Track-to-track association of every pair of tracks: what the ``fusion`` node computes, without ROS.

``PairAssociator`` keeps the latest report per track (``TrackTable``) and the source of each
track. ``score(t)`` brings every live track to ``t``, enumerates the pairs i < j of the table's
order, masks the pairs of one source (a source does not report a ship twice) unless
``same_source_pairs``, scores them in one batch (geofeasibility, paper eqs. 49–71; ``mc`` shares
one draw among the pairs of an instant), adds the clipped instant score to the pair's window of
the last ``window`` instants, combines the window (harmonic or geometric mean, §1), associates
the pair when the combination is ≥ ``threshold`` and fuses each associated pair by covariance
intersection (their correlation is unknown).

Isolation: when the batch fails (a degenerate covariance slipped past the caller's checks), each
pair is scored alone; a pair whose score raises (or comes out not finite) is skipped and reported in
``Instant.skipped`` (ids and reason, its window untouched) and every other pair is scored as
usual. Valid input never takes that path, so its results (and the ``mc`` draws) are unchanged.

With ``stamp_rate`` the instants are those of the data (``StampSchedule``): ``push`` queues a
report and returns the instants it made due, each scored with the reports stamped up to it.
Without it ``push`` applies the report at once and the caller scores at its own ticks.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from track_core.filters.covariance_intersection import covariance_intersection
from track_core.fusion.schedule import StampSchedule
from track_core.fusion.tracks import TrackReport, TrackTable
from track_core.geofeasibility import ScoreWindow, score

METHODS = ('exact', 'glr', 'glr_thresholded', 'mc')


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
    pairs: tuple[PairScore, ...] = ()
    fused: tuple[FusedPair, ...] = ()
    error: str | None = None
    skipped: tuple[tuple[str, str, str], ...] = ()


class PairAssociator:
    def __init__(self, method: str = 'exact', threshold: float = 0.5, combine: str = 'geometric',
                 window: int = 10, *, n_samples: int = 500, same_source_pairs: bool = False,
                 stale_after: float = 2.0, max_prediction: float = 10.0, q_s: float = 0.0, seed: int = 0,
                 stamp_rate: float | None = None) -> None:
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
        self.history: dict[tuple[str, str], ScoreWindow] = {}
        self.schedule = StampSchedule(stamp_rate) if stamp_rate is not None else None

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

    def score(self, t: float) -> Instant | None:
        """Score every pair of live tracks at ``t``; None when there is no pair to score."""
        ids, mu, R = self.table.at(t)
        if len(ids) < 2:
            return None
        i, j = self.pairs_at(ids)
        if i.size == 0:
            return None
        try:
            s = np.atleast_1d(score(mu[i], R[i], mu[j], R[j], self.method, n_samples=self.n_samples,
                                    rng=self.rng, shared_samples=True))
            failed = {int(k): f'scoring failed: non-finite score {s[k]}' for k in np.flatnonzero(~np.isfinite(s))}
        except (ValueError, np.linalg.LinAlgError):
            s = np.full(i.size, np.nan)
            failed = self._score_each(mu, R, i, j, s)
        pairs, fused = [], []
        skipped = tuple((ids[i[k]], ids[j[k]], reason) for k, reason in failed.items())
        for k, (a, b) in enumerate(zip(i.tolist(), j.tolist(), strict=True)):
            if k in failed:
                continue
            key = (ids[a], ids[b])
            hist = self.history.setdefault(key, ScoreWindow(self.combine, max_instants=self.window))
            hist.add(t, float(np.clip(s[k], 0.0, 1.0)))
            combined = hist.value()
            associated = bool(combined >= self.threshold)
            pairs.append(PairScore(key[0], key[1], a, b, float(s[k]), float(combined), len(hist), associated))
            if associated:
                m, P, _ = covariance_intersection(mu[a], R[a], mu[b], R[b])
                fused.append(FusedPair(key[0], key[1], m, P))
        return Instant(t, ids, mu, R, tuple(pairs), tuple(fused), skipped=skipped)

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
