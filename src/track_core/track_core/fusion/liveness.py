"""Which tracks were live at each scored instant, kept as intervals of instant indices per track.

A pair's geofeasibility window (``PairWindows``) holds its last min(n, K) instant scores, n being
the instants at which the pair was scored. With a gate most pairs are never scored: a pair outside
the candidates scores exactly 0 there. So the associator passes only the candidates, and n comes
from here: the pair was "in" every scored instant at which both of its tracks were live, and
``colive(a, b, upto)`` counts those instants without having stored anything per pair.

Scored instants are numbered 0, 1, 2, … by :meth:`LiveIntervals.mark`. A track's live instants are
its current interval [start, last] plus the closed intervals before its last drop-out (``past``),
so a track that stays live costs two integers, and one that drops out and back costs one interval
per drop-out. ``colive`` is vectorised over pairs whose tracks never dropped out (the common case:
the overlap of two intervals); pairs with a drop-out merge their interval lists one by one.
"""

from __future__ import annotations

import numpy as np

_NEVER = np.iinfo(np.int64).max // 4


class LiveIntervals:
    def __init__(self) -> None:
        self.m = -1                                   # index of the latest scored instant
        self.start = np.zeros(0, np.int64)            # start of each track's current interval
        self.last = np.zeros(0, np.int64)             # its latest live instant (-1: never live)
        self.past: dict[int, list[tuple[int, int]]] = {}   # closed intervals before a drop-out

    def mark(self, slots) -> int:
        """A new scored instant at which the tracks ``slots`` (integer ids) are live; → its index."""
        slots = np.asarray(slots, np.int64)
        self.m += 1
        m = self.m
        need = int(slots.max(initial=-1)) + 1
        if need > self.start.size:
            grow = need - self.start.size
            self.start = np.concatenate([self.start, np.full(grow, _NEVER, np.int64)])
            self.last = np.concatenate([self.last, np.full(grow, -1, np.int64)])
        last = self.last[slots]
        gap = (last >= 0) & (last < m - 1)
        for s in slots[gap].tolist():                 # one interval closes per drop-out
            self.past.setdefault(s, []).append((int(self.start[s]), int(self.last[s])))
        self.start[slots[gap | (last < 0)]] = m
        self.last[slots] = m
        return m

    def live_at(self, slots, m: int) -> np.ndarray:
        """True where track ``slots[k]`` is live at the latest instant ``m`` (only the latest is kept this way)."""
        slots = np.asarray(slots, np.int64)
        ok = slots < self.last.size
        out = np.zeros(slots.size, bool)
        out[ok] = self.last[slots[ok]] == m
        return out

    def colive(self, a, b, upto: int) -> np.ndarray:
        """Scored instants ≤ ``upto`` at which both tracks a[k] and b[k] were live (int64, per pair)."""
        a, b = np.asarray(a, np.int64), np.asarray(b, np.int64)
        lo = np.maximum(self.start[a], self.start[b])
        hi = np.minimum(np.minimum(self.last[a], self.last[b]), upto)
        n = np.maximum(hi - lo + 1, 0)
        if self.past:
            keys = np.fromiter(self.past, np.int64, len(self.past))
            for k in np.flatnonzero(np.isin(a, keys) | np.isin(b, keys)).tolist():
                n[k] = _overlap(self._intervals(int(a[k])), self._intervals(int(b[k])), upto)
        return n

    def _intervals(self, s: int) -> list[tuple[int, int]]:
        cur = [(int(self.start[s]), int(self.last[s]))] if self.last[s] >= 0 else []
        return self.past.get(s, []) + cur


def _overlap(x: list[tuple[int, int]], y: list[tuple[int, int]], upto: int) -> int:
    """Integers ≤ ``upto`` in both unions of sorted, disjoint closed intervals."""
    i = j = n = 0
    while i < len(x) and j < len(y):
        lo, hi = max(x[i][0], y[j][0]), min(x[i][1], y[j][1], upto)
        n += max(hi - lo + 1, 0)
        if x[i][1] < y[j][1]:
            i += 1
        else:
            j += 1
    return n
