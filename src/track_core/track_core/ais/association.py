"""Track-to-track association of two sources' local tracks, and its evaluation against MMSI truth.

1. Pairs at common instants (:func:`pair_instants`): at every instant both sources report (times
   equal within ``tol``), every report of A with every report of B; never same-source pairs.
2. Scores (:meth:`PairTable.score`): one batched ``geofeasibility.score`` call per method (``mc``: N
   = 500 draws a pair). An exact pre-gate skips pairs whose centres are further apart than the sum
   of the two 2σ semi-major axes: ``exact``, ``glr_thresholded`` and ``mc`` are 0 there (``glr`` is
   computed for every pair); gated pairs count as evaluations.
3. Decision (:meth:`PairTable.decide`): the instant scores of a pair are combined over the last
   ``window`` common instants by the paper's geometric (or harmonic) mean, as the fusion node's
   ``ScoreWindow``; associated at an instant when ≥ ``threshold`` (0.5), the same ship when
   associated at at least half of its common instants (not the paper's mean over all instants, which
   one zero vetoes). ``combined`` is the mean of the windowed scores. Short pairs (``prior_weight``
   ν > 0): declared when k ≥ 1 and (k + ν·r̄)/(n + ν) ≥ 1/2 (Beta prior of ν instants at
   ``prior_rate`` r̄ = 0.8); ν = 0 (default) is the plain majority.
4. One-to-one (``one_to_one=True``, :func:`match_one_to_one`): the matching maximising the sum of
   the combined scores (``scipy.optimize.linear_sum_assignment``).
5. Bounded memory (:class:`StreamingDecisions`, :func:`pair_tables`): chunks of about ``max_pairs``
   pair-instants (an instant never split) folded into dense n_A × n_B per-pair sums; the decisions
   equal one table's over the whole run (``mc`` draws chunk by chunk).
6. Metrics (:func:`evaluate`): the same ship when both tracks carry the same MMSI; precision = TP /
   declared, recall = TP / true pairs with a common instant, F1 their harmonic mean; true pairs
   without a common instant are ``undecidable``. The reasons, measured: docs/results/fusion.md, "The
   association rule and its reasons".
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, replace

import numpy as np

from track_core.ais.sources import SourceReports
from track_core.geofeasibility.ellipse import gaussian_to_ellipse
from track_core.geofeasibility.scores import score
from track_core.geofeasibility.track import MEANS, THRESHOLD

GATED_METHODS = ('exact', 'glr_thresholded', 'mc')


@dataclass
class PairInstants:
    """Report indices (ia into source A, ib into source B) of every cross pair at a common instant."""

    ia: np.ndarray
    ib: np.ndarray

    def __len__(self) -> int:
        return self.ia.size


def pair_instants(a: SourceReports, b: SourceReports, tol: float = 1e-3) -> PairInstants:
    """All cross-source report pairs at the instants both sources report (equal within ``tol``)."""
    if not tol > 0:
        raise ValueError(f'tol must be > 0 s, got {tol}')
    ka = np.round(a.t / tol).astype(np.int64)
    kb = np.round(b.t / tol).astype(np.int64)
    oa, ob = np.argsort(ka, kind='stable'), np.argsort(kb, kind='stable')
    ua, sa, na = np.unique(ka[oa], return_index=True, return_counts=True)
    ub, sb, nb = np.unique(kb[ob], return_index=True, return_counts=True)
    common, ca, cb = np.intersect1d(ua, ub, assume_unique=True, return_indices=True)
    if common.size == 0:
        return PairInstants(np.empty(0, int), np.empty(0, int))
    na_c, nb_c = na[ca], nb[cb]
    sizes = na_c * nb_c
    inst = np.repeat(np.arange(common.size), sizes)                # instant of each pair
    within = np.arange(sizes.sum()) - np.repeat(np.cumsum(sizes) - sizes, sizes)
    ia = oa[sa[ca][inst] + within // nb_c[inst]]
    ib = ob[sb[cb][inst] + within % nb_c[inst]]
    return PairInstants(ia, ib)


def _semi_major(R: np.ndarray) -> np.ndarray:
    """2σ semi-major axis 2√λ_max of each (n, 2, 2) covariance (eqs. 56–59 inverted)."""
    return gaussian_to_ellipse(np.zeros(R.shape[:-1]), R)[2]


class PairTable:
    """The pair-instants of two sources with what every method and decision rule reuses.

    Built once per pair of sources: the gate (pairs whose 2σ ellipses can touch), and the
    grouping of pair-instants by track pair in time order.
    """

    def __init__(self, a: SourceReports, b: SourceReports, tol: float = 1e-3) -> None:
        self.a, self.b = a, b
        self.pi = pi = pair_instants(a, b, tol)
        reach = _semi_major(a.R)[pi.ia] + _semi_major(b.R)[pi.ib]
        d = a.mu[pi.ia] - b.mu[pi.ib]
        self.near = np.flatnonzero(np.einsum('ij,ij->i', d, d) <= reach * reach)
        nb = len(b.ids)
        key = a.track[pi.ia].astype(np.int64) * nb + b.track[pi.ib]
        self.order = np.lexsort((a.t[pi.ia], key))                 # by pair, then time
        keys, self.start, self.counts = np.unique(key[self.order], return_index=True, return_counts=True)
        self.group = np.repeat(np.arange(keys.size), self.counts)
        self.pair_a, self.pair_b = keys // nb, keys % nb
        self.same = a.mmsi[self.pair_a] == b.mmsi[self.pair_b]     # truth, evaluation only

    def __len__(self) -> int:
        return len(self.pi)

    def score(self, method: str, *, n_samples: int = 500, rng: np.random.Generator | None = None,
              gate: bool = True) -> tuple[np.ndarray, int]:
        """Instant score of every pair-instant with ``method``; returns (scores, pairs whose geometry was computed)."""
        a, b, pi = self.a, self.b, self.pi
        idx = self.near if gate and method in GATED_METHODS else np.arange(len(pi))
        g = np.zeros(len(pi))
        if idx.size:
            ia, ib = pi.ia[idx], pi.ib[idx]
            g[idx] = score(a.mu[ia], a.R[ia], b.mu[ib], b.R[ib], method, n_samples=n_samples, rng=rng)
        return np.clip(g, 0.0, 1.0), int(idx.size)

    def decide(self, g: np.ndarray, *, window: int = 1, mean: str = 'geometric', threshold: float = THRESHOLD,
               one_to_one: bool = False, prior_weight: float = 0.0, prior_rate: float = 0.8) -> PairDecisions:
        """Windowed track scores and same-ship decisions per track pair (see the module docstring)."""
        _check_rule(window, mean)
        n = self.counts.size
        w = _windowed(g[self.order], self.start, self.counts, window, mean)
        comb = np.bincount(self.group, weights=w, minlength=n)
        k = np.bincount(self.group, weights=(w >= threshold), minlength=n)
        return _decisions(self.pair_a, self.pair_b, self.counts, comb, k, one_to_one, prior_weight, prior_rate)


def _check_rule(window: int | None, mean: str) -> None:
    if mean not in MEANS:
        raise ValueError(f'unknown mean {mean!r}; choose one of {", ".join(MEANS)}')
    if window is not None and window < 1:
        raise ValueError(f'window must be >= 1 instant or None (all), got {window}')


SHORT_PAIR_WEIGHT = 2.0
"""ν of the short-pair rule used by the experiment and the ``ais`` scenario's summary (step 3)."""
SHORT_PAIR_RATE = 0.8
"""r̄ of the short-pair rule (step 3)."""


def declare(n: np.ndarray, k: np.ndarray, prior_weight: float = 0.0, prior_rate: float = 0.8) -> np.ndarray:
    """Same-ship verdict of pairs with ``k`` of ``n`` instants associated (module docstring, step 3)."""
    if not prior_weight >= 0 or not 0.0 <= prior_rate <= 1.0:
        raise ValueError(f'need prior_weight >= 0 and prior_rate in [0, 1], got {prior_weight}, {prior_rate}')
    if prior_weight == 0:
        return k / n >= 0.5
    return (k >= 1) & ((k + prior_weight * prior_rate) / (n + prior_weight) >= 0.5)


def _decisions(pa, pb, n, comb, k, one_to_one, prior_weight, prior_rate) -> PairDecisions:
    declared = declare(n, k, prior_weight, prior_rate)
    combined = comb / n
    if one_to_one and declared.any():
        declared = match_one_to_one(pa, pb, combined, declared)
    return PairDecisions(pa, pb, n, combined, k / n, declared)


def pair_tables(a: SourceReports, b: SourceReports, max_pairs: int = 1_000_000, tol: float = 1e-3):
    """PairTables of consecutive time chunks of ≤ ``max_pairs`` + one instant's pair-instants (instants stay whole).

    The reports of each source must be sorted by time (as :func:`~.sources.simulate_source` returns
    them); the chunks hold views of them with the sources' global track indices.
    """
    if not max_pairs >= 1:
        raise ValueError(f'max_pairs must be >= 1, got {max_pairs}')
    if np.any(np.diff(a.t) < 0) or np.any(np.diff(b.t) < 0):
        raise ValueError('pair_tables needs the reports of each source sorted by time')
    ka = np.round(a.t / tol).astype(np.int64)
    kb = np.round(b.t / tol).astype(np.int64)
    ua, na = np.unique(ka, return_counts=True)
    ub, nb = np.unique(kb, return_counts=True)
    common, ca, cb = np.intersect1d(ua, ub, assume_unique=True, return_indices=True)
    if common.size == 0:
        return
    cum = np.cumsum(na[ca] * nb[cb])
    # chunk c holds the instants whose cumulative pair count falls in (c·max_pairs, (c+1)·max_pairs]
    cut = np.flatnonzero(np.diff((cum - 1) // max_pairs)) + 1
    for lo, hi in itertools.pairwise([0, *cut.tolist(), common.size]):   # one pass per chunk
        k_lo, k_hi = common[lo], common[hi - 1]
        sa = slice(int(np.searchsorted(ka, k_lo)), int(np.searchsorted(ka, k_hi, side='right')))
        sb = slice(int(np.searchsorted(kb, k_lo)), int(np.searchsorted(kb, k_hi, side='right')))
        yield PairTable(_slice(a, sa), _slice(b, sb), tol)


def _slice(r: SourceReports, s: slice) -> SourceReports:
    return replace(r, t=r.t[s], track=r.track[s], mu=r.mu[s], R=r.R[s], truth=r.truth[s])


class StreamingDecisions:
    """Per-track-pair sums of windowed scores over consecutive chunks (see the module docstring, step 5).

    ``rules`` maps (window, mean) → the thresholds to count; window ``None`` is all instants.
    ``add(table, g)`` folds one chunk (a :class:`PairTable` of the same two sources, chunks in
    time order); ``decide(...)`` gives the :class:`PairDecisions` of one (window, mean, threshold).
    """

    def __init__(self, n_a: int, n_b: int, rules: dict[tuple[int | None, str], list[float]]) -> None:
        for window, mean in rules:
            _check_rule(window, mean)
        self.n_a, self.n_b = n_a, n_b
        size = n_a * n_b
        self.rules = {key: list(th) for key, th in rules.items()}
        self.n = np.zeros(size, np.int64)
        self.comb = {key: np.zeros(size) for key in rules}
        self.k = {(key, th): np.zeros(size, np.int64) for key, ths in rules.items() for th in ths}
        self.state = {}
        for key in rules:
            window = key[0]
            if window is None:
                self.state[key] = (np.zeros(size), np.zeros(size, np.int64), np.zeros(size, np.int64))
            elif window > 1:
                self.state[key] = np.full((size, window - 1), np.nan)

    def add(self, table: PairTable, g: np.ndarray) -> None:
        gs = np.clip(g[table.order], 0.0, 1.0)
        pk = table.pair_a * self.n_b + table.pair_b                     # global pair key of each group
        self.n[pk] += table.counts
        grp = table.group
        for key, ths in self.rules.items():
            window, mean = key
            if window == 1:
                w = _windowed(gs, table.start, table.counts, 1, mean)
            elif window is None:
                w = self._all_instants(key, gs, table, pk)
            else:
                w = self._carried(key, gs, table, pk)
            self.comb[key][pk] += np.bincount(grp, weights=w, minlength=pk.size)
            for th in ths:
                self.k[key, th][pk] += np.bincount(grp, weights=w >= th, minlength=pk.size).astype(np.int64)

    def _carried(self, key, gs, table: PairTable, pk) -> np.ndarray:
        """Sliding window of W instants: each group is prefixed with its pair's last W − 1 scores."""
        window, mean = key
        last = self.state[key]
        carry = last[pk]                                                 # (G, W − 1), right-aligned
        valid = ~np.isnan(carry)
        c = valid.sum(1)
        ext_counts = table.counts + c
        ext_start = np.cumsum(ext_counts) - ext_counts
        ext = np.empty(int(ext_counts.sum()))
        rows, cols = np.nonzero(valid)
        ext[ext_start[rows] + cols - (window - 1 - c[rows])] = carry[rows, cols]
        pos = np.arange(gs.size) - np.repeat(table.start, table.counts)
        at = ext_start[table.group] + c[table.group] + pos
        ext[at] = gs
        w = _windowed(ext, ext_start, ext_counts, window, mean)[at]
        new = np.full_like(carry, np.nan)
        end = ext_start + ext_counts
        for j in range(window - 1):                                      # window slots, not pairs
            idx = end - (window - 1) + j
            ok = idx >= ext_start
            new[ok, j] = ext[idx[ok]]
        last[pk] = new
        return w

    def _all_instants(self, key, gs, table: PairTable, pk) -> np.ndarray:
        """The mean over all instants so far (running sums carried across chunks)."""
        mean = key[1]
        sf, sz, sn = self.state[key]
        pos_g = np.where(gs > 0, gs, 1.0)
        f = np.where(gs > 0, np.log(pos_g) if mean == 'geometric' else 1.0 / pos_g, 0.0)
        z = (gs <= 0).astype(np.int64)
        first = np.repeat(table.start, table.counts)
        cf, cz = np.cumsum(f), np.cumsum(z)
        run_f = cf - np.concatenate([[0.0], cf])[first] + sf[pk][table.group]
        run_z = cz - np.concatenate([[0], cz])[first] + sz[pk][table.group]
        k = np.arange(gs.size) - first + 1 + sn[pk][table.group]
        with np.errstate(divide='ignore', invalid='ignore', over='ignore'):
            v = np.exp(run_f / k) if mean == 'geometric' else k / run_f
        sf[pk] += np.bincount(table.group, weights=f, minlength=pk.size)
        sz[pk] += np.bincount(table.group, weights=z, minlength=pk.size).astype(np.int64)
        sn[pk] += table.counts
        return np.where(run_z > 0, 0.0, np.clip(v, 0.0, 1.0))

    def decide(self, window: int | None = 1, mean: str = 'geometric', threshold: float = THRESHOLD, *,
               one_to_one: bool = False, prior_weight: float = 0.0, prior_rate: float = 0.8) -> PairDecisions:
        key = (window, mean)
        if (key, threshold) not in self.k:
            raise ValueError(f'rule window={window}, mean={mean}, threshold={threshold} was not accumulated')
        keys = np.flatnonzero(self.n)
        return _decisions(keys // self.n_b, keys % self.n_b, self.n[keys], self.comb[key][keys],
                          self.k[key, threshold][keys], one_to_one, prior_weight, prior_rate)


@dataclass
class PairDecisions:
    """Per track pair (local index ``a`` of source A, ``b`` of source B)."""

    a: np.ndarray
    b: np.ndarray
    instants: np.ndarray        # common instants scored
    combined: np.ndarray        # mean of the windowed track scores
    associated: np.ndarray      # fraction of the instants at which the windowed score was ≥ threshold
    declared: np.ndarray        # bool: declared the same ship


def _windowed(g_sorted: np.ndarray, start: np.ndarray, counts: np.ndarray, window: int, mean: str) -> np.ndarray:
    """Windowed combination for groups stored contiguously in time order; vectorised over all pairs.

    Element k of group q combines g over its last ``window`` elements (fewer at the start), as
    ``ScoreWindow(mean, max_instants=window)`` does: geometric exp(mean log g), harmonic
    n / Σ 1/g; 0 as soon as one g in the window is 0.
    """
    n = g_sorted.size
    pos = np.arange(n) - np.repeat(start, counts)              # position within the group
    zero = (g_sorted <= 0).astype(np.int64)
    pos_g = np.where(g_sorted > 0, g_sorted, 1.0)
    f = np.log(pos_g) if mean == 'geometric' else 1.0 / pos_g
    f = np.where(g_sorted > 0, f, 0.0)
    csum = np.concatenate([[0.0], np.cumsum(f)])
    czero = np.concatenate([[0], np.cumsum(zero)])
    hi = np.arange(n) + 1
    lo = hi - np.minimum(pos + 1, window)
    k = hi - lo
    s = csum[hi] - csum[lo]
    any_zero = (czero[hi] - czero[lo]) > 0
    with np.errstate(divide='ignore', invalid='ignore', over='ignore'):
        v = np.exp(s / k) if mean == 'geometric' else k / s
    return np.where(any_zero, 0.0, np.clip(v, 0.0, 1.0))


def match_one_to_one(pa: np.ndarray, pb: np.ndarray, combined: np.ndarray, declared: np.ndarray) -> np.ndarray:
    """Keep the declared pairs of a maximum-weight one-to-one matching (weights: combined score)."""
    from scipy.optimize import linear_sum_assignment

    d = np.flatnonzero(declared)
    ra, inv_a = np.unique(pa[d], return_inverse=True)
    rb, inv_b = np.unique(pb[d], return_inverse=True)
    cost = np.zeros((ra.size, rb.size))
    cost[inv_a, inv_b] = -(combined[d] + 1.0)                     # +1: any declared pair beats no pair
    rows, cols = linear_sum_assignment(cost)
    chosen = np.zeros((ra.size, rb.size), bool)
    chosen[rows, cols] = True
    out = np.zeros_like(declared)
    out[d] = chosen[inv_a, inv_b]
    return out


@dataclass
class Metrics:
    tp: int
    fp: int
    fn: int
    undecidable: int

    @property
    def precision(self) -> float:
        return self.tp / (self.tp + self.fp) if self.tp + self.fp else 1.0

    @property
    def recall(self) -> float:
        return self.tp / (self.tp + self.fn) if self.tp + self.fn else 1.0

    @property
    def f1(self) -> float:
        p, r = self.precision, self.recall
        return 2 * p * r / (p + r) if p + r else 0.0

    def as_dict(self) -> dict[str, float | int]:
        return {'precision': self.precision, 'recall': self.recall, 'f1': self.f1, 'tp': self.tp, 'fp': self.fp,
                'fn': self.fn, 'undecidable': self.undecidable}


def evaluate(a: SourceReports, b: SourceReports, dec: PairDecisions) -> Metrics:
    """Precision/recall/F1 of the declared pairs against MMSI truth (see the module docstring)."""
    return evaluate_mmsi(a.mmsi, b.mmsi, dec)


def evaluate_mmsi(mmsi_a: np.ndarray, mmsi_b: np.ndarray, dec: PairDecisions) -> Metrics:
    """:func:`evaluate` from the two sources' track → MMSI tables only."""
    same = mmsi_a[dec.a] == mmsi_b[dec.b]
    tp = int(np.sum(dec.declared & same))
    fp = int(np.sum(dec.declared & ~same))
    fn = int(np.sum(~dec.declared & same))
    n_true = np.intersect1d(mmsi_a, mmsi_b).size                   # ships with a track in both sources
    return Metrics(tp, fp, fn, n_true - int(same.sum()))
