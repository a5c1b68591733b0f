"""``track-bench fusion-scale``: gated exact scoring against scoring every pair, on Solent layouts.

Layout (``solent_layout``): the radar and patrol sources of the ``ais`` scenario
(``track_core.ais.RADAR``/``PATROL``: 1σ 15 × 8 m across the beam, 60 × 20 m at random bearings)
are simulated over the whole Solent AIS file (``ais_solent/``, the real ships' positions); a
picture of n tracks takes n/2 reports of each source at random (seeded, without replacement),
each report one track with its position and 2σ ellipse. The reports span the file's 84 minutes,
so a moored ship contributes many tracks at one spot: the picture is denser than any single
instant, which makes more candidate pairs (a pessimistic case for the gate).

Per row (100, 1000 and 10,000 tracks; ``--quick``: 100 and 1000):

- ``gated_s``: :func:`track_core.geofeasibility.gate.candidate_pairs` (cKDTree radius gate and the
  separating-ellipse test) plus the exact score (eq. 49) of the candidates: one scoring cycle
  of every pair (best of ``runs``);
- ``all_pairs_s``: the exact score of every pair i < j in the same run (chunks of
  ``CHUNK`` pairs). When ``sampled`` (10,000 tracks, and 1000 under ``--quick``), a uniform
  random sample of ``sample_pairs`` pairs is scored and the time scaled by pairs / sample;
- ``max_abs_diff``: max |gated − all pairs| over every pair (or over the sample), the gated
  value being 0 outside the candidates; ``nonzero_pairs``: pairs with a positive exact score.
"""

from __future__ import annotations

import time

import numpy as np

from track_core.geofeasibility.gate import candidate_pairs
from track_core.geofeasibility.scores import score
from track_experiments.cli import Outcome, RunConfig, format_table

CHUNK = 50_000
SIZES = (100, 1000, 10_000)
QUICK_SIZES = (100, 1000)


def solent_layout(n: int, rng: np.random.Generator, reports=None) -> tuple[np.ndarray, np.ndarray]:
    """(μ (n, 2), R (n, 2, 2)) of n tracks: n/2 radar and n − n/2 patrol reports on the Solent ships."""
    radar, patrol = reports if reports is not None else solent_reports(rng)
    if n // 2 > len(radar) or n - n // 2 > len(patrol):
        raise ValueError(f'{n} tracks need {n // 2} radar and {n - n // 2} patrol reports; '
                         f'the simulation has {len(radar)} and {len(patrol)}')
    a = rng.choice(len(radar), n // 2, replace=False)
    b = rng.choice(len(patrol), n - n // 2, replace=False)
    return np.concatenate([radar.mu[a], patrol.mu[b]]), np.concatenate([radar.R[a], patrol.R[b]])


def solent_reports(rng: np.random.Generator):
    """Every report of the radar and patrol sources over the Solent file (OSError when the data are absent)."""
    from track_core.ais import PATROL, RADAR, ShipTruth, read_ais, simulate_source

    truth = ShipTruth(read_ais())
    return simulate_source(truth, RADAR, rng), simulate_source(truth, PATROL, rng)


def score_chunked(mu, R, i, j) -> np.ndarray:
    """Exact scores of pairs (i[k], j[k]) in chunks of ``CHUNK`` (rows are independent: same values)."""
    out = np.empty(i.size)
    for lo in range(0, i.size, CHUNK):
        a, b = i[lo:lo + CHUNK], j[lo:lo + CHUNK]
        out[lo:lo + CHUNK] = score(mu[a], R[a], mu[b], R[b], 'exact')
    return out


def _pair_index(i, j, n):
    return i.astype(np.int64) * n + j


def _gated(mu, R):
    ci, cj = candidate_pairs(mu, R)
    return ci, cj, score_chunked(mu, R, ci, cj)


def _best(fn, repeat: int):
    best, out = float('inf'), None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def _sample_pairs(n: int, m: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """m distinct pairs i < j drawn uniformly among the n(n − 1)/2 (by rejection of i = j and duplicates)."""
    keys = np.zeros(0, np.int64)
    while keys.size < m:
        a, b = rng.integers(0, n, (2, 2 * m))
        ok = a != b
        i, j = np.minimum(a, b)[ok], np.maximum(a, b)[ok]
        keys = np.unique(np.concatenate([keys, _pair_index(i, j, n)]))
    keys = rng.permutation(keys)[:m]
    return np.sort(keys) // n, np.sort(keys) % n


def scale_row(mu, R, repeat: int, rng: np.random.Generator, sample: int | None) -> dict:
    """One row of the table for the tracks (μ, R); ``sample`` pairs for all_pairs_s, or None for every pair."""
    n = len(mu)
    pairs = n * (n - 1) // 2
    gated_s, (ci, cj, cs) = _best(lambda: _gated(mu, R), repeat)
    cand_keys = _pair_index(ci, cj, n)
    if sample is None or sample >= pairs:
        i, j = np.triu_indices(n, 1)
        sampled = False
    else:
        i, j = _sample_pairs(n, sample, rng)
        sampled = True
    all_s, ref = _best(lambda: score_chunked(mu, R, i, j), 1 if sampled else repeat)
    gated = np.zeros(i.size)
    keys = _pair_index(i, j, n)
    pos = np.clip(np.searchsorted(cand_keys, keys), 0, max(cand_keys.size - 1, 0))
    found = (cand_keys[pos] == keys) if cand_keys.size else np.zeros(i.size, bool)
    gated[found] = cs[pos[found]]
    row = {'tracks': n, 'pairs': pairs, 'candidate_pairs': int(ci.size), 'nonzero_pairs': int(np.sum(cs > 0)),
           'gated_s': gated_s, 'all_pairs_s': all_s * pairs / i.size,
           'max_abs_diff': float(np.max(np.abs(gated - ref))), 'sampled': sampled}
    if sampled:
        row.update(sample_pairs=int(i.size), sample_candidates=int(found.sum()), sample_all_pairs_s=all_s)
    row['speedup'] = row['all_pairs_s'] / gated_s
    return row


def bench(cfg: RunConfig) -> Outcome:
    rng = np.random.default_rng(cfg.seed)
    repeat = cfg.n_runs(full=3, quick=1)
    reports = solent_reports(rng)
    rows = []
    for n in QUICK_SIZES if cfg.quick else SIZES:
        mu, R = solent_layout(n, rng, reports)
        sample = (20_000 if n >= 1000 else None) if cfg.quick else (200_000 if n > 1000 else None)
        rows.append(scale_row(mu, R, repeat, rng, sample))
    table = format_table(['tracks', 'pairs', 'candidates', 'nonzero', 'gated s', 'all pairs s', 'speedup',
                          'max |diff|', 'all pairs'],
                         [[r['tracks'], r['pairs'], r['candidate_pairs'], r['nonzero_pairs'], r['gated_s'],
                           r['all_pairs_s'], r['speedup'], r['max_abs_diff'],
                           f'sampled {r["sample_pairs"]} pairs, scaled' if r['sampled'] else 'every pair']
                          for r in rows])
    table += (f'\nexact score (eq. 49); radar {len(reports[0])} and patrol {len(reports[1])} reports on the '
              f'Solent ships; gated = cKDTree radius gate + separating-ellipse test + exact score of the '
              f'candidates; best of {repeat}')
    return Outcome(table, {'rows': rows, 'method': 'exact',
                           'layout': 'Solent AIS: n/2 radar + n/2 patrol reports (real ship positions, '
                                     'the ais scenario sources\' 2σ ellipses)'})
