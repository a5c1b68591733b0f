"""``track-bench geofeasibility``: scores per second for 100,000 random pairs, all in one run.

Paper's requirement: 100,000 evaluations per hour (≈ 28 pairs/s); the paper measured GLR at
4 s and MC (N = 500) at 100 s per 100k, one pair per call. Measured here, on the same pairs
(the fig6 population, :func:`.experiments.random_pairs`):

- our batched ``score`` for ``glr``, ``exact`` and ``mc`` (N = 500), input checks included;
- the per-pair Python loops of the same maths, the way the paper ran it:
  :func:`.scores.glr_pair` (``np.linalg.solve`` + ``exp`` per pair) and :func:`.scores.mc_pair`
  (the identical estimator and random stream; it returns bit-for-bit the batched values);
- shapely (the peer a user would otherwise pick): both 2σ ellipses as 256-vertex polygons,
  ``intersection`` and ``area`` with shapely 2's vectorised functions; building the polygons
  from (μ, R) is included in the time. Reported as ``null`` when shapely is not importable.

Rates are pairs per second (best of ``runs`` repetitions; default 3, 1 under ``--quick``).
``--quick`` uses 2,000 pairs.
"""

from __future__ import annotations

import logging
import time

import numpy as np

from track_core.geofeasibility.scores import glr_pair, mc_pair, score
from track_experiments.cli import Outcome, RunConfig, format_table
from track_experiments.geofeasibility.experiments import random_pairs

log = logging.getLogger(__name__)
N_VERTICES = 256


def _best(fn, repeat: int) -> float:
    best = float('inf')
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def _polygon_coords(mu: np.ndarray, R: np.ndarray, k: int = N_VERTICES) -> np.ndarray:
    """(n, k + 1, 2) closed rings of the 2σ ellipses: μ + 2 L (cos a, sin a), L Lᵀ = R."""
    a = np.linspace(0.0, 2 * np.pi, k, endpoint=False)
    circle = np.stack([np.cos(a), np.sin(a)], -1)
    pts = mu[:, None, :] + 2.0 * np.einsum('nij,kj->nki', np.linalg.cholesky(R), circle)
    return np.concatenate([pts, pts[:, :1]], axis=1)


def shapely_overlap(mu1, R1, mu2, R2, k: int = N_VERTICES) -> np.ndarray:
    """Normalized overlap of k-vertex polygon approximations by shapely (ImportError if absent)."""
    import shapely

    p1 = shapely.polygons(_polygon_coords(mu1, R1, k))
    p2 = shapely.polygons(_polygon_coords(mu2, R2, k))
    inter = shapely.area(shapely.intersection(p1, p2))
    return inter / np.minimum(shapely.area(p1), shapely.area(p2))


def bench(cfg: RunConfig) -> Outcome:
    n = 2_000 if cfg.quick else 100_000
    repeat = cfg.n_runs(full=3, quick=1)
    rng = np.random.default_rng(cfg.seed)
    mu1, R1, mu2, R2 = (np.ascontiguousarray(v) for v in random_pairs(n, rng))
    rate: dict[str, float | None] = {}

    rate['glr_pairs_per_s'] = n / _best(lambda: score(mu1, R1, mu2, R2, 'glr'), repeat)
    rate['glr_loop_pairs_per_s'] = n / _best(
        lambda: [glr_pair(mu1[i], R1[i], mu2[i], R2[i]) for i in range(n)], repeat)
    rate['exact_pairs_per_s'] = n / _best(lambda: score(mu1, R1, mu2, R2, 'exact'), repeat)
    rate['mc500_pairs_per_s'] = n / _best(lambda: score(mu1, R1, mu2, R2, 'mc', 500, rng), repeat)
    rate['mc500_shared_pairs_per_s'] = n / _best(
        lambda: score(mu1, R1, mu2, R2, 'mc', 500, rng, shared_samples=True), repeat)
    rate['mc500_loop_pairs_per_s'] = n / _best(
        lambda: [mc_pair(mu1[i], R1[i], mu2[i], R2[i], 500, rng) for i in range(n)], repeat)
    try:
        import shapely  # noqa: F401

        shp_err = float(np.max(np.abs(shapely_overlap(mu1[:200], R1[:200], mu2[:200], R2[:200])
                                      - score(mu1[:200], R1[:200], mu2[:200], R2[:200], 'exact'))))
        rate['shapely256_pairs_per_s'] = n / _best(lambda: shapely_overlap(mu1, R1, mu2, R2), repeat)
    except ImportError as exc:
        log.warning('shapely unavailable, peer not measured: %s', exc)
        rate['shapely256_pairs_per_s'], shp_err = None, None

    def ratio(a: str, b: str) -> float | None:
        return rate[a] / rate[b] if rate[a] and rate[b] else None

    rows = [
        ['glr batched', rate['glr_pairs_per_s'], 100_000 / rate['glr_pairs_per_s'], ''],
        ['glr per-pair loop', rate['glr_loop_pairs_per_s'], 100_000 / rate['glr_loop_pairs_per_s'],
         f'batched {ratio("glr_pairs_per_s", "glr_loop_pairs_per_s"):.0f}x faster (need >= 100x)'],
        ['mc N=500 batched', rate['mc500_pairs_per_s'], 100_000 / rate['mc500_pairs_per_s'], ''],
        ['mc N=500 per-pair loop', rate['mc500_loop_pairs_per_s'], 100_000 / rate['mc500_loop_pairs_per_s'],
         f'batched {ratio("mc500_pairs_per_s", "mc500_loop_pairs_per_s"):.1f}x faster (need >= 20x)'],
        ['mc N=500 shared draws', rate['mc500_shared_pairs_per_s'], 100_000 / rate['mc500_shared_pairs_per_s'],
         f'{ratio("mc500_shared_pairs_per_s", "mc500_loop_pairs_per_s"):.1f}x the loop (one draw for all pairs)'],
        ['exact batched', rate['exact_pairs_per_s'], 100_000 / rate['exact_pairs_per_s'], ''],
    ]
    if rate['shapely256_pairs_per_s']:
        rows.append(['shapely 256-vertex', rate['shapely256_pairs_per_s'], 100_000 / rate['shapely256_pairs_per_s'],
                     f'exact {ratio("exact_pairs_per_s", "shapely256_pairs_per_s"):.1f}x faster; '
                     f'max |shapely − exact| {shp_err:.1e}'])
    else:
        rows.append(['shapely 256-vertex', 'unavailable', '-', 'shapely not importable'])
    text = format_table(['method', 'pairs/s', 's per 100k', 'note'], rows)
    text += (f'\n{n} pairs, best of {repeat}; paper: GLR 4 s and MC(500) 100 s per 100k; '
             'requirement 100k per hour')
    return Outcome(text, {'pairs': n, **rate})
