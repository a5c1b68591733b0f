"""Per-instant view of ``maritime-seeds`` (``--set instants=yes``): where the true pair's instant scores fail.

For every scored instant t (seconds from the run's start) over the runs: the mean NEES (2 dof, against
the truth) of the sonar track and of the network track, the share of runs whose instant score of the
true pair is below the association threshold, and that share *if both trackers were consistent*: each
track's error drawn from N(0, P) of its own reported covariance (``DRAWS`` draws per run and instant,
a fixed-seed Generator) and scored with the same geofeasibility method. The difference between the
last two columns is what the association owes to trackers whose ellipses are wider than their errors
(a NEES mean below 2): the score asks the smaller 2σ ellipse to lie half inside the other, which two
consistent tracks of similar size miss at about one instant in four.
"""

from __future__ import annotations

import numpy as np

from track_core.geofeasibility import score
from track_core.geofeasibility.track import THRESHOLD
from track_core.metrics import match_stamps, nees_or_nan

DRAWS = 200     # draws per run and instant for the consistent-trackers column
SEED = 20261205


def instant_rows(d: dict, rows: list[dict], scores: dict, sonar: str, network: str, start: float) -> list[dict]:
    """Per network step with a sonar report and a pair score: t, the two NEES, the score, the two covariances.

    ``d``: ``maritime_sim.simulate``'s run; ``rows``: ``network_replay.replay``'s steps; ``scores``:
    ``network_replay.fuse``'s pair rows; ``sonar`` / ``network``: the two track ids; ``start``: the run's start.
    """
    ts, xs, Ps = d['tracks'][sonar]
    tt, xt = d['truth'][sonar]
    it, ie = match_stamps(tt, ts)
    truth_at = {float(ts[e]): xt[i][:2] for i, e in zip(it, ie, strict=True)}
    index = {float(t): k for k, t in enumerate(ts)}
    pair = {float(r[0]): float(r[1]) for r in scores.get(tuple(sorted((sonar, network))), [])}
    out = []
    for r in rows:
        t = float(r['t'])
        k = index.get(t)
        if k is None or t not in truth_at or t not in pair:
            continue
        P_s, P_n = np.asarray(Ps[k], float)[:2, :2], np.asarray(r['cov'], float)
        nees, _ = nees_or_nan(np.array([xs[k][:2] - truth_at[t], r['mean'] - r['truth']]), np.array([P_s, P_n]))
        out.append({'t': round(t - start, 6), 'nees_sonar': float(nees[0]), 'nees_network': float(nees[1]),
                    'score': pair[t], 'P_sonar': P_s, 'P_network': P_n})
    return out


def consistent_share(P_s: np.ndarray, P_n: np.ndarray, rng: np.random.Generator, method: str = 'exact',
                     threshold: float = THRESHOLD, draws: int = DRAWS) -> float | np.ndarray:
    """Share of draws whose instant score is below ``threshold`` when both errors follow their covariances,
    per pair of covariances (``P_s``, ``P_n``: (2, 2) → a float, or (m, 2, 2) → (m,), scored in one batch);
    NaN where a covariance is not positive definite (no Gaussian to draw from)."""
    single = np.ndim(P_s) == 2
    P_s, P_n = (np.asarray(P, float).reshape(-1, 2, 2) for P in (P_s, P_n))
    ok = (np.linalg.eigvalsh(P_s)[:, 0] > 0) & (np.linalg.eigvalsh(P_n)[:, 0] > 0)
    eye = np.eye(2)
    L_s = np.linalg.cholesky(np.where(ok[:, None, None], P_s, eye))
    L_n = np.linalg.cholesky(np.where(ok[:, None, None], P_n, eye))
    m = P_s.shape[0]
    e_s = np.einsum('mij,mdj->mdi', L_s, rng.standard_normal((m, draws, 2)))
    e_n = np.einsum('mij,mdj->mdi', L_n, rng.standard_normal((m, draws, 2)))
    cov = (np.broadcast_to(np.where(ok[:, None, None], P, eye)[:, None], (m, draws, 2, 2)).reshape(-1, 2, 2)
           for P in (P_s, P_n))
    g = score(e_s.reshape(-1, 2), next(cov), e_n.reshape(-1, 2), next(cov), method).reshape(m, draws)
    share = np.where(ok, np.mean(g < threshold, axis=1), np.nan)
    return float(share[0]) if single else share


def instants_table(runs: list[list[dict]], method: str = 'exact', threshold: float = THRESHOLD,
                   draws: int = DRAWS) -> tuple[list[list], list[dict]]:
    """Rows (t, runs, sonar NEES, network NEES, % score < threshold, % if consistent) over the runs'
    ``instant_rows``, and the same as records for JSON."""
    rng = np.random.default_rng(SEED)
    by_t: dict[float, list[dict]] = {}
    for run in runs:
        for r in run:
            by_t.setdefault(r['t'], []).append(r)
    rows, data = [], []
    for t in sorted(by_t):
        rs = by_t[t]
        cons = consistent_share(np.array([r['P_sonar'] for r in rs]), np.array([r['P_network'] for r in rs]),
                                rng, method, threshold, draws)
        rec = {'t': t, 'runs': len(rs),
               'nees_sonar': float(np.nanmean([r['nees_sonar'] for r in rs])),
               'nees_network': float(np.nanmean([r['nees_network'] for r in rs])),
               'below': float(np.mean([r['score'] < threshold for r in rs])),
               'below_if_consistent': float(np.nanmean(cons)) if np.isfinite(cons).any() else float('nan')}
        data.append(rec)
        rows.append([t, rec['runs'], rec['nees_sonar'], rec['nees_network'], 100 * rec['below'],
                     100 * rec['below_if_consistent']])
    return rows, data
