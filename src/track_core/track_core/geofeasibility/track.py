"""Track-level geofeasibility: combine per-instant scores over the common instants (paper §1).

The paper scores one common time instant and says several such scores "would be combined
(probably by using a harmonic or geometric mean)" into a track score. Here:

- **Common instants** (:func:`common_instants`): the report times of track 1 that have a
  report of track 2 within ``tol`` seconds (nearest one, each report used at most once). No
  interpolation: bringing tracks to common instants by prediction is the caller's job (the
  fusion node predicts with the track velocity before scoring).
- **Window**: only the common instants in the last ``window`` seconds, [t_last − window,
  t_last] with t_last the newest common instant, and at most the newest ``max_instants`` of
  them; ``None`` disables either limit. Old geometry stops vetoing a pair after ``window``.
- **Means** (:func:`combine_scores`): harmonic K / Σ 1/g_k or geometric exp(mean ln g_k).
  Both are ≤ the arithmetic mean and are 0 as soon as one instant scores 0: one instant at
  which the ellipses are disjoint makes the pair infeasible within the window.
"""

from __future__ import annotations

from collections import deque

import numpy as np

from track_core.geofeasibility.scores import score

MEANS = ('harmonic', 'geometric')


def combine_scores(scores, mean: str = 'harmonic') -> float:
    """Harmonic or geometric mean of per-instant scores in [0, 1]; 0 if any score is 0."""
    g = np.asarray(scores, dtype=float).ravel()
    if mean not in MEANS:
        raise ValueError(f'unknown mean {mean!r}; choose one of {", ".join(MEANS)}')
    if g.size == 0:
        raise ValueError('no scores to combine (no common instants in the window)')
    if not np.all(np.isfinite(g)) or np.any((g < 0) | (g > 1)):
        raise ValueError(f'scores must be finite and in [0, 1], got {g[~((g >= 0) & (g <= 1))][:5].tolist()}')
    if np.any(g == 0.0):
        return 0.0
    if mean == 'harmonic':
        return float(g.size / np.sum(1.0 / g))
    return float(np.exp(np.mean(np.log(g))))


def common_instants(t1, t2, tol: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
    """Indices (i1, i2) of matched report times, |t1[i1] − t2[i2]| ≤ tol, in time order."""
    t1, t2 = np.asarray(t1, dtype=float), np.asarray(t2, dtype=float)
    if t1.size == 0 or t2.size == 0:
        return np.empty(0, int), np.empty(0, int)
    order = np.argsort(t2, kind='stable')
    ts = t2[order]
    j = np.clip(np.searchsorted(ts, t1), 1, ts.size - 1) if ts.size > 1 else np.zeros(t1.size, int)
    if ts.size > 1:
        j = np.where(np.abs(ts[j - 1] - t1) <= np.abs(ts[j] - t1), j - 1, j)
    ok = np.abs(ts[j] - t1) <= tol
    i1 = np.flatnonzero(ok)
    i2 = order[j[ok]]
    _, first = np.unique(i2, return_index=True)   # each report of track 2 used once
    keep = np.sort(first)
    i1, i2 = i1[keep], i2[keep]
    o = np.argsort(t1[i1], kind='stable')
    return i1[o], i2[o]


def track_score(t1, mu1, R1, t2, mu2, R2, *, method: str = 'exact', mean: str = 'harmonic',
                window: float | None = None, max_instants: int | None = None, tol: float = 1e-6,
                n_samples: int = 500, rng: np.random.Generator | None = None) -> float:
    """Combined score of two tracks given as report times (k,), means (k, 2), covariances (k, 2, 2).

    Raises ``ValueError`` when the tracks have no common instant in the window.
    """
    i1, i2 = common_instants(t1, t2, tol)
    t = np.asarray(t1, dtype=float)[i1]
    keep = np.ones(t.size, bool)
    if window is not None and t.size:
        keep &= t >= t.max() - window
    if max_instants is not None:
        keep &= np.arange(t.size) >= t.size - max_instants
    i1, i2 = i1[keep], i2[keep]
    if i1.size == 0:
        raise ValueError('tracks have no common instant in the window')
    g = score(np.asarray(mu1, float)[i1], np.asarray(R1, float)[i1], np.asarray(mu2, float)[i2],
              np.asarray(R2, float)[i2], method, n_samples=n_samples, rng=rng)
    return combine_scores(g, mean)


class ScoreWindow:
    """Streaming version for one pair: ``add(t, g)`` per common instant, ``value()`` combined.

    Keeps the instants in [t_newest − window, t_newest] and at most ``max_instants`` of them.
    """

    def __init__(self, mean: str = 'harmonic', window: float | None = None, max_instants: int | None = None):
        if mean not in MEANS:
            raise ValueError(f'unknown mean {mean!r}; choose one of {", ".join(MEANS)}')
        if window is not None and not window > 0:
            raise ValueError(f'window must be > 0 seconds or None, got {window}')
        if max_instants is not None and max_instants < 1:
            raise ValueError(f'max_instants must be >= 1 or None, got {max_instants}')
        self.mean, self.window = mean, window
        self._buf: deque[tuple[float, float]] = deque(maxlen=max_instants)

    def add(self, t: float, g: float) -> None:
        if self._buf and t < self._buf[-1][0]:
            raise ValueError(f'time went backwards: {t} < {self._buf[-1][0]}')
        if not (np.isfinite(g) and 0.0 <= g <= 1.0):
            raise ValueError(f'score must be in [0, 1], got {g}')
        self._buf.append((float(t), float(g)))
        if self.window is not None:
            while self._buf[0][0] < t - self.window:
                self._buf.popleft()

    def __len__(self) -> int:
        return len(self._buf)

    def value(self) -> float:
        """Combined score of the instants in the window; ``ValueError`` when empty."""
        return combine_scores([g for _, g in self._buf], self.mean)
