"""``track-experiment demo-kf``: the NEES consistency of the constant-velocity Kalman demo.

``demo-kf`` (track-experiment): M Monte-Carlo runs of CVTarget + CVKalmanTracker, all M
advanced together. The average NEES over runs, M·ANEES_k ~ χ²(4M) when the filter is
consistent, so the two-sided 95 % interval is χ²⁻¹(0.025, 4M)/M … χ²⁻¹(0.975, 4M)/M and
about 95 % of the steps should fall inside it.
"""

from __future__ import annotations

import numpy as np
from scipy.stats import chi2

from track_core.demo.simulator import CVTarget
from track_core.demo.tracker import CVKalmanTracker
from track_core.filters import mahalanobis_sq
from track_experiments.cli import Outcome, RunConfig, format_table
from track_experiments.plotting import pyplot

X0 = np.array([0.0, 5.0, 0.0, 2.0])


def run_nees(n_runs: int, n_steps: int, seed: int, T: float = 0.1, q_s: float = 0.05,
             r: float = 2.0, r_filter: float | None = None) -> dict:
    """ANEES per step over ``n_runs`` vectorised runs and its 95 % χ² interval.

    ``r_filter`` (default ``r``) is the report noise the tracker assumes; a mismatch makes the
    filter inconsistent, which is how the tests show that the NEES check can fail.
    """
    rng = np.random.default_rng(seed)
    R = np.diag([r**2, r**2])
    R_filter = R if r_filter is None else np.diag([r_filter**2, r_filter**2])
    target = CVTarget(np.tile(X0, (n_runs, 1)), T=T, q_s=q_s, R=R)
    tracker = CVKalmanTracker(q_s=q_s, sigma_v0=5.0)
    anees = np.empty(n_steps)
    for k in range(n_steps):
        truth = target.step(rng)
        x, P = tracker.update(target.t, target.report(rng), R_filter)
        anees[k] = mahalanobis_sq(truth - x, P).mean()
    lo, hi = chi2.ppf([0.025, 0.975], 4 * n_runs) / n_runs
    return {'anees': anees, 'lo': float(lo), 'hi': float(hi)}


def nees_experiment(cfg: RunConfig) -> Outcome:
    n_runs = cfg.n_runs(full=500, quick=50)
    n_steps = 60 if cfg.quick else 300
    res = run_nees(n_runs, n_steps, cfg.seed)
    anees = res['anees'][10:]  # after the velocity prior has been forgotten
    inside = float(np.mean((anees >= res['lo']) & (anees <= res['hi'])))
    table = format_table(
        ['runs', 'steps', 'mean ANEES', 'expected', '95% lo', '95% hi', 'steps inside'],
        [[n_runs, n_steps, float(anees.mean()), 4.0, res['lo'], res['hi'], f'{100 * inside:.1f}%']],
    )
    fig = cfg.out / 'demo-kf-anees.png'
    _plot(res, fig)
    return Outcome(table, {'runs': n_runs, 'steps': n_steps, 'mean_anees': float(anees.mean()),
                           'interval': [res['lo'], res['hi']], 'fraction_inside': inside}, [fig])


def _plot(res: dict, path) -> None:
    plt = pyplot()

    fig, ax = plt.subplots(figsize=(7, 3.5))
    ax.plot(res['anees'], lw=1, label='ANEES')
    ax.axhline(res['lo'], color='k', ls='--', lw=0.8, label='95 % χ² interval')
    ax.axhline(res['hi'], color='k', ls='--', lw=0.8)
    ax.set_xlabel('step')
    ax.set_ylabel('average NEES (4 states)')
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
