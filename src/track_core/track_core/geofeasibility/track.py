"""Track-level geofeasibility: combine per-instant scores over the common instants (paper §1).

The paper scores one common time instant and says several such scores "would be combined (probably
by using a harmonic or geometric mean)" into a track score. Here:

- **Common instants** (:func:`common_instants`): the report times of track 1 that have a report of
  track 2 within ``tol`` s (nearest, each used once). No interpolation: the caller predicts.
- **Window**: the common instants in [t_last − ``window``, t_last], at most the newest
  ``max_instants``; ``None`` disables either limit.
- **Means** (:func:`combine_scores`): harmonic K / Σ 1/g_k or geometric exp(mean ln g_k); both are 0
  as soon as one instant scores 0.
- **Floor** ε (``floor``, default 0 = the paper's means): every instant enters as max(g_k, ε), so a
  disjoint instant (eq. 47: g = 0) costs ε^(1/n) in the geometric mean instead of a veto; a window
  with no positive score still combines to 0. ``FLOOR_2SIGMA`` = e⁻² (a consistent 2σ ellipse
  misses its target with probability e⁻²; the maritime scenario uses it).
- **Prior** ν, s̄ (:func:`with_prior`, default ν = 0): ν more instants scoring s̄ enter the mean:
  geometric exp((Σ ln g_k + ν ln s̄)/(n + ν)), harmonic (n + ν)/(Σ 1/g_k + ν/s̄); a combination of 0
  stays 0. It leans towards association, the paper's asymmetry (§3). Why the floor and the prior:
  docs/MODULES.md, "Floor and prior of the track score".
"""

from __future__ import annotations

from collections import deque

import numpy as np

from track_core.geofeasibility.scores import score

MEANS = ('harmonic', 'geometric')
#: the floor of a disjoint instant argued in the module docstring: a 2σ ellipse misses its target with probability e⁻²
FLOOR_2SIGMA = float(np.exp(-2.0))
#: a pair whose combined score reaches this is taken as one ship (the default of every decision rule)
THRESHOLD = 0.5


def check_floor(floor: float) -> float:
    """The floor ε of the module docstring, checked: a number in [0, 1)."""
    if not (isinstance(floor, int | float | np.floating | np.integer) and 0.0 <= floor < 1.0):
        raise ValueError(f'floor must be a number in [0, 1), got {floor!r}')
    return float(floor)


def combine_scores(scores, mean: str = 'harmonic', floor: float = 0.0) -> float:
    """Harmonic or geometric mean of per-instant scores in [0, 1]; 0 if any score is 0 (``floor`` 0), else
    the mean of max(g, ``floor``), and 0 when no score is positive (module docstring)."""
    g = np.asarray(scores, dtype=float).ravel()
    if mean not in MEANS:
        raise ValueError(f'unknown mean {mean!r}; choose one of {", ".join(MEANS)}')
    floor = check_floor(floor)
    if g.size == 0:
        raise ValueError('no scores to combine (no common instants in the window)')
    if not np.all(np.isfinite(g)) or np.any((g < 0) | (g > 1)):
        raise ValueError(f'scores must be finite and in [0, 1], got {g[~((g >= 0) & (g <= 1))][:5].tolist()}')
    if floor > 0.0 and np.any(g > 0.0):
        g = np.maximum(g, floor)
    if np.any(g == 0.0):
        return 0.0
    if mean == 'harmonic':
        return float(g.size / np.sum(1.0 / g))
    return float(np.exp(np.mean(np.log(g))))


def check_prior(weight: float, score: float) -> tuple[float, float]:
    """The prior (ν, s̄) of the module docstring, checked: ν ≥ 0 and s̄ in (0, 1]."""
    ok = all(isinstance(v, int | float | np.floating | np.integer) and np.isfinite(v) for v in (weight, score))
    if not (ok and weight >= 0.0 and 0.0 < score <= 1.0):
        raise ValueError(f'need prior weight >= 0 and prior score in (0, 1], got {weight!r}, {score!r}')
    return float(weight), float(score)


def with_prior(combined, n, mean: str, weight: float, score: float) -> np.ndarray:
    """The combinations ``combined`` of windows of ``n`` instants with the prior (ν = ``weight`` instants
    scoring s̄ = ``score``) in their mean (module docstring); 0 stays 0, ν = 0 returns them unchanged."""
    c = np.asarray(combined, dtype=float)
    if weight == 0.0:
        return c
    n = np.asarray(n, dtype=float)
    pos = c > 0.0
    safe = np.where(pos, c, 1.0)
    if mean == 'harmonic':
        out = (n + weight) / (n / safe + weight / score)
    else:
        out = np.exp((n * np.log(safe) + weight * np.log(score)) / (n + weight))
    return np.where(pos, out, 0.0)


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
                n_samples: int = 500, rng: np.random.Generator | None = None, floor: float = 0.0) -> float:
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
    return combine_scores(g, mean, floor)


class ScoreWindow:
    """Streaming version for one pair: ``add(t, g)`` per common instant, ``value()`` combined.

    Keeps the instants in [t_newest − window, t_newest] and at most ``max_instants`` of them;
    ``floor``: see the module docstring.
    """

    def __init__(self, mean: str = 'harmonic', window: float | None = None, max_instants: int | None = None,
                 floor: float = 0.0):
        self.floor = check_floor(floor)
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
        return combine_scores([g for _, g in self._buf], self.mean, self.floor)


class PairWindows:
    """:class:`ScoreWindow` (``max_instants`` K only) for many pairs, of which a call passes only some.

    ``add(keys, g, t, total)``: pair ``keys[k]`` scored ``g[k]`` at ``t``, and ``total[k]`` counts the
    instants at which the pair was scored so far, this one included. Every such instant that no
    call passed scored 0 (what a gate's non-candidates score exactly), so a caller passes only the
    pairs it scored. A pair's window holds its last n = min(total, K) instant scores, and their mean
    is 0 as soon as one of them is 0 (the paper's means). So only the pairs whose newest score is
    positive are stored, each with the trailing run of its positive scores (at most K, newest
    last) and the total at its last call: the run continues only when that total is ``total − 1``
    (otherwise an instant no call passed scored 0 and broke it). The combination is the mean of the
    last n scores when the run is at least n long, and 0 otherwise. Equal, instant by instant, to
    one ``ScoreWindow(mean, max_instants=K)`` per pair fed every instant (tests compare them).
    Vectorised over pairs; the means are taken per window length in one batch.

    With ``floor`` ε > 0 (module docstring) a zero no longer breaks the window, so the stored pairs
    are those with a positive score within their last n instants, each with its last K scores
    (``vals``, right-aligned, zeros included) and the total at its last call; the instants between
    two calls scored 0. The combination is the mean of max(g, ε) over the last n, or 0 when none of
    them is positive; again equal to ``ScoreWindow(mean, max_instants=K, floor=ε)`` per pair (tests).
    A caller must then pass every stored pair whose tracks are both live (with score 0 when it is
    not a candidate), since its combination may stay above a threshold for a few instants.
    """

    def __init__(self, mean: str = 'harmonic', max_instants: int = 10, floor: float = 0.0) -> None:
        if mean not in MEANS:
            raise ValueError(f'unknown mean {mean!r}; choose one of {", ".join(MEANS)}')
        if max_instants < 1:
            raise ValueError(f'max_instants must be >= 1, got {max_instants}')
        self.mean, self.k, self.floor = mean, int(max_instants), check_floor(floor)
        self.keys = np.zeros(0, np.int64)         # pairs with a positive newest score, sorted
        self.total = np.zeros(0, np.int64)        # the pair's total at its last call
        self.run_len = np.zeros(0, np.int64)
        self.run_vals = np.zeros((0, 0))          # trailing positive scores, right-aligned (newest last)
        self.vals = np.zeros((0, self.k))         # floor > 0: the last K scores, right-aligned (newest last)
        self.last_t: float | None = None

    def __len__(self) -> int:
        return self.keys.size

    def add(self, keys, g, t: float, total) -> tuple[np.ndarray, np.ndarray]:
        """Add score ``g[k]`` at ``t`` to pair ``keys[k]`` (each key once); → (combined (P,), instants n (P,))."""
        keys, g, total = np.asarray(keys, np.int64), np.asarray(g, float), np.asarray(total, np.int64)
        if keys.size == 0:
            return np.zeros(0), np.zeros(0, np.int64)
        if self.last_t is not None and t < self.last_t:
            raise ValueError(f'time went backwards: {t} < {self.last_t}')
        if not np.all(np.isfinite(g) & (g >= 0.0) & (g <= 1.0)):
            raise ValueError(f'scores must be in [0, 1], got {g[~((g >= 0) & (g <= 1))][:5].tolist()}')
        if np.any(total < 1):
            raise ValueError(f'total must count this instant (>= 1), got {total[total < 1][:5].tolist()}')
        self.last_t = float(t)
        if self.floor > 0.0:
            return self._add_floored(keys, g, total)
        count = np.minimum(total, self.k)
        pos, found = _lookup(self.keys, keys)
        found &= (self.total[pos] == total - 1) if self.keys.size else found
        prev_len = np.where(found, self.run_len[pos] if self.keys.size else 0, 0)
        pos_g = g > 0.0
        run_len = np.where(pos_g, np.minimum(prev_len + 1, self.k), 0)
        width = int(max(self.run_vals.shape[1], run_len.max(initial=0)))
        kp = np.flatnonzero(pos_g)
        vals = np.full((kp.size, width), np.nan)
        if width:
            cont = kp[prev_len[kp] > 0]
            if cont.size and width > 1:
                old = np.full((self.keys.size, width), np.nan)
                old[:, width - self.run_vals.shape[1]:] = self.run_vals
                vals[np.searchsorted(kp, cont), :-1] = old[pos[cont], 1:]
            vals[:, -1] = g[kp]
        keep = ~_lookup(np.sort(keys), self.keys)[1]   # runs of pairs not in this call
        old_vals = self.run_vals[keep]
        if old_vals.shape[1] < width:
            old_vals = np.concatenate([np.full((old_vals.shape[0], width - old_vals.shape[1]), np.nan), old_vals], 1)
        rk = np.concatenate([self.keys[keep], keys[kp]])
        order = np.argsort(rk, kind='stable')
        self.keys = rk[order]
        self.total = np.concatenate([self.total[keep], total[kp]])[order]
        self.run_len = np.concatenate([self.run_len[keep], run_len[kp]])[order]
        self.run_vals = np.concatenate([old_vals, vals])[order]
        # combination: positive when the run covers the whole window
        combined = np.zeros(keys.size)
        full = pos_g & (run_len >= count)
        for n in np.unique(count[full]):
            sel = np.flatnonzero(full & (count == n))
            w = np.ascontiguousarray(vals[np.searchsorted(kp, sel), width - n:])
            combined[sel] = _combine_rows(w, self.mean)
        return combined, count

    def _add_floored(self, keys: np.ndarray, g: np.ndarray, total: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``add`` with a floor ε > 0 (class docstring): windows of the last K scores, zeros floored at ε."""
        k = self.k
        count = np.minimum(total, k)
        pos, found = _lookup(self.keys, keys)
        vals = np.zeros((keys.size, k))
        if found.any():
            shift = np.maximum(total[found] - self.total[pos[found]], 1)   # instants since its last call
            src = np.arange(k)[None, :] + shift[:, None]                   # new column c ← old column c + shift
            old = np.take_along_axis(self.vals[pos[found]], np.minimum(src, k - 1), axis=1)
            vals[found] = np.where(src < k, old, 0.0)                      # the instants between: scored 0
        vals[:, -1] = g
        in_window = np.arange(k)[None, :] >= (k - count)[:, None]
        positive = np.any((vals > 0.0) & in_window, axis=1)
        combined = np.zeros(keys.size)
        for n in np.unique(count[positive]):
            sel = np.flatnonzero(positive & (count == n))
            combined[sel] = _combine_rows(np.maximum(vals[sel, k - n:], self.floor), self.mean)
        keep = ~_lookup(np.sort(keys), self.keys)[1]   # stored pairs not in this call
        rk = np.concatenate([self.keys[keep], keys[positive]])
        order = np.argsort(rk, kind='stable')
        self.keys = rk[order]
        self.total = np.concatenate([self.total[keep], total[positive]])[order]
        self.vals = np.concatenate([self.vals[keep], vals[positive]])[order]
        self.run_len = np.zeros(self.keys.size, np.int64)   # unused with a floor
        return combined, count

    def drop(self, mask) -> None:
        """Forget the stored runs where ``mask`` (over ``keys``) holds (runs known to be broken)."""
        keep = ~np.asarray(mask, bool)
        self.keys, self.total, self.run_len = self.keys[keep], self.total[keep], self.run_len[keep]
        if self.floor > 0.0:
            self.vals = self.vals[keep]
        else:
            self.run_vals = self.run_vals[keep]


def _lookup(sorted_keys: np.ndarray, keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Positions of ``keys`` in ``sorted_keys`` and whether each is there."""
    if sorted_keys.size == 0:
        return np.zeros(keys.size, np.intp), np.zeros(keys.size, bool)
    pos = np.minimum(np.searchsorted(sorted_keys, keys), sorted_keys.size - 1)
    return pos, sorted_keys[pos] == keys


def _combine_rows(g: np.ndarray, mean: str) -> np.ndarray:
    """:func:`combine_scores` of each row of positive scores (m, n), the same arithmetic along the rows."""
    if mean == 'harmonic':
        return g.shape[1] / np.sum(1.0 / g, axis=1)
    return np.exp(np.mean(np.log(g), axis=1))
