"""Track-to-track association of two sources' local tracks, and its evaluation against MMSI truth.

1. **Pairs at common instants** (:func:`pair_instants`): at every instant at which both
   sources report (times equal within ``tol``; the default sources share a time grid), every
   report of source A is paired with every report of source B: all cross-source pairs, as the
   fusion node scores them. Same-source pairs are never formed (a source does not report a
   ship twice).
2. **Scores** (:meth:`PairTable.score`): one batched ``geofeasibility.score`` call per method
   over all pair-instants (``mc``: N = 500 independent draws per pair). An exact pre-gate
   skips the geometry of pairs whose centres are further apart than the sum of the two 2σ
   semi-major axes: their ellipses cannot overlap, so ``exact``, ``glr_thresholded`` and ``mc``
   are exactly 0 there (``glr`` is computed for every pair). Gated pairs count as evaluations
   (the value is exact, just cheap).
3. **Decision per track pair** (:meth:`PairTable.decide`): the instant scores of one pair are
   combined over a sliding window of the last ``window`` common instants by the paper's
   geometric (or harmonic) mean — what the fusion node's ``ScoreWindow`` does at each tick;
   the pair is *associated* at an instant when that windowed score is ≥ ``threshold`` (0.5),
   and declared **the same ship** when it is associated at at least half of its common
   instants (the fusion summary's "associated most of the time"). With the default
   ``window=1`` this is "the median instant score is ≥ the threshold". Why not the paper's
   mean over all common instants: with consistent 2σ ellipses the true position lies outside
   a source's ellipse 13.5 % of the time (e⁻²), so a same-ship pair scores exactly 0 at some
   instants (``exact``, default sources: ~4.6 % of them) and any harmonic/geometric mean
   containing one zero is 0: over the whole file that mean finds ~17 % of the true pairs
   (experiment table "decision rule"); a window of W instants is vetoed with probability
   1 − 0.954^W, so short windows and a majority vote are used. ``combined`` (the weight of the
   one-to-one step) is the mean of a pair's windowed scores.
4. **One-to-one** (``one_to_one=True``, :func:`match_one_to_one`): a source reports a ship
   under one local track, so a track may match at most one track of the other source. Among
   the declared pairs, the matching maximising the sum of the combined scores (Hungarian
   algorithm, ``scipy.optimize.linear_sum_assignment``; every declared pair outweighs no
   pair) is kept. Without it, ships moored 5–40 m apart — closer than the patrol's ellipses —
   are all declared feasible with each other (precision ~0.75 on the Solent file).
5. **Truth and metrics** (:func:`evaluate`): a pair is truly the same ship when both local
   tracks carry the same MMSI. Only pairs with at least one common instant can be decided;
   precision = TP / declared, recall = TP / true pairs with a common instant, F1 their harmonic
   mean. True pairs without any common instant are counted separately (``undecidable``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from track_core.ais.sources import SourceReports
from track_core.geofeasibility.ellipse import gaussian_to_ellipse
from track_core.geofeasibility.scores import score
from track_core.geofeasibility.track import MEANS

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

    def decide(self, g: np.ndarray, *, window: int = 1, mean: str = 'geometric', threshold: float = 0.5,
               one_to_one: bool = False) -> PairDecisions:
        """Windowed track scores and same-ship decisions per track pair (see the module docstring)."""
        if mean not in MEANS:
            raise ValueError(f'unknown mean {mean!r}; choose one of {", ".join(MEANS)}')
        if window < 1:
            raise ValueError(f'window must be >= 1 instant, got {window}')
        n = self.counts.size
        w = _windowed(g[self.order], self.start, self.counts, window, mean)
        combined = np.bincount(self.group, weights=w, minlength=n) / self.counts
        frac = np.bincount(self.group, weights=(w >= threshold), minlength=n) / self.counts
        declared = frac >= 0.5
        if one_to_one and declared.any():
            declared = match_one_to_one(self.pair_a, self.pair_b, combined, declared)
        return PairDecisions(self.pair_a, self.pair_b, self.counts, combined, frac, declared)


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
    same = a.mmsi[dec.a] == b.mmsi[dec.b]
    tp = int(np.sum(dec.declared & same))
    fp = int(np.sum(dec.declared & ~same))
    fn = int(np.sum(~dec.declared & same))
    n_true = np.intersect1d(a.mmsi, b.mmsi).size                   # ships with a track in both sources
    return Metrics(tp, fp, fn, n_true - int(same.sum()))
