"""Experiments reproducing the paper's figures 2, 5 and 6 (``track-experiment geo-fig2`` …).

- ``geo-fig2``: two circles of radius 1 at distances d ∈ [0, 2] (the analytic case). MC with
  N = 500 over ``runs`` trials (default 1000) per distance: mean ± standard deviation, with
  ``exact`` and the closed-form lens area alongside.
- ``geo-fig5``: MSE of MC against N for two unit circles whose normalized overlap is 0.391;
  the slope of 10·log10(MSE) against log2(N) is the change in dB per doubling of N (paper:
  −3 dB, i.e. MSE ∝ 1/N). ``runs`` trials per N (default 2000).
- ``geo-fig6``: ``runs`` random ellipse pairs (default 10,000; semi-axes U(0.5, 3), bearings
  U(0, π), centre distance U(0, r_max1 + r_max2) in a uniform direction) sorted by ``exact``,
  with MC (N = 1000), GLR and thresholded GLR. Reports where GLR over- and under-estimates
  (sign of the mean GLR − exact in ten overlap bins) and the mean absolute error of each
  method against ``exact``.
"""

from __future__ import annotations

import itertools

import numpy as np
from scipy.optimize import brentq

from track_core.geofeasibility.reference import circle_overlap, random_pairs
from track_core.geofeasibility.scores import score
from track_experiments.cli import Outcome, RunConfig, format_table
from track_experiments.plotting import pyplot


def _circles(d: np.ndarray, r: float = 1.0):
    n = d.size
    R = np.broadcast_to(np.eye(2) * (r * r / 4.0), (n, 2, 2))  # 2σ radius r
    return np.zeros((n, 2)), R, np.stack([d, np.zeros(n)], 1), R


def _fig_path(cfg: RunConfig, name: str):
    cfg.out.mkdir(parents=True, exist_ok=True)
    return cfg.out / name



def fig2(cfg: RunConfig) -> Outcome:
    """Overlapping unit circles: MC (N = 500) error bars over ``runs`` trials vs analytic and exact."""
    trials = cfg.n_runs(full=1000, quick=100)
    n_samples = 500
    dist = np.linspace(0.0, 2.0, 11 if cfg.quick else 21)
    rng = np.random.default_rng(cfg.seed)
    analytic = circle_overlap(1.0, 1.0, dist)
    exact = score(*_circles(dist), 'exact')
    rows, table = [], []
    for k in cfg.progress(range(dist.size), desc='geo-fig2'):
        m1, R1, m2, R2 = _circles(np.full(trials, dist[k]))
        g = score(m1, R1, m2, R2, 'mc', n_samples=n_samples, rng=rng)
        rows.append({'d': float(dist[k]), 'analytic': float(analytic[k]), 'exact': float(exact[k]),
                     'mc_mean': float(g.mean()), 'mc_std': float(g.std(ddof=1))})
        table.append([float(dist[k]), float(analytic[k]), float(exact[k]), float(g.mean()), float(g.std(ddof=1))])
    err = float(np.max(np.abs(exact - analytic)))
    fig = _fig_path(cfg, 'geo-fig2.png')
    plt = pyplot()
    f, ax = plt.subplots(figsize=(6, 4))
    ax.plot(analytic, analytic, 'k-', lw=1, label='analytic (= exact)')
    ax.errorbar(analytic, [r['mc_mean'] for r in rows], yerr=[r['mc_std'] for r in rows], fmt='o', ms=3,
                capsize=3, label=f'MC N={n_samples}, ±1σ over {trials} trials')
    ax.set_xlabel('true normalized overlap')
    ax.set_ylabel('estimated normalized overlap')
    ax.legend()
    f.tight_layout()
    f.savefig(fig, dpi=100)
    plt.close(f)
    text = format_table(['d', 'analytic', 'exact', 'MC mean', 'MC std'], table)
    text += f'\nmax |exact − analytic| = {err:.3g}'
    return Outcome(text, {'n_samples': n_samples, 'trials': trials, 'rows': rows,
                          'max_abs_exact_minus_analytic': err}, [fig])


def fig5(cfg: RunConfig) -> Outcome:
    """MC mean squared error against N at a fixed overlap of 0.391; slope in dB per doubling."""
    target = 0.391
    d = brentq(lambda x: float(circle_overlap(1.0, 1.0, x)) - target, 0.0, 2.0, xtol=1e-14)
    trials = cfg.n_runs(full=2000, quick=300)
    ns = [2**k for k in range(5, 11 if cfg.quick else 14)]
    rng = np.random.default_rng(cfg.seed)
    m1, R1, m2, R2 = _circles(np.full(trials, d))
    rows = []
    for n in cfg.progress(ns, desc='geo-fig5'):
        g = score(m1, R1, m2, R2, 'mc', n_samples=n, rng=rng)
        rows.append({'n': n, 'mse': float(np.mean((g - target) ** 2))})
    x = np.log2([r['n'] for r in rows])
    y = 10.0 * np.log10([r['mse'] for r in rows])
    slope = float(np.polyfit(x, y, 1)[0])
    fig = _fig_path(cfg, 'geo-fig5.png')
    plt = pyplot()
    f, ax = plt.subplots(figsize=(6, 4))
    ax.semilogx([r['n'] for r in rows], y, 'o-', base=2, label='MC')
    ax.semilogx([r['n'] for r in rows], y[0] - 10 * np.log10(2) * (x - x[0]), 'k--', base=2, lw=0.8,
                label='−3.01 dB per doubling')
    ax.set_xlabel('number of samples N')
    ax.set_ylabel('MSE (dB)')
    ax.set_title(f'overlap {target}, {trials} trials per N; fit {slope:.2f} dB/doubling')
    ax.legend()
    f.tight_layout()
    f.savefig(fig, dpi=100)
    plt.close(f)
    text = format_table(['N', 'MSE', 'MSE dB'], [[r['n'], r['mse'], float(v)] for r, v in zip(rows, y, strict=True)])
    text += f'\nslope: {slope:.3f} dB per doubling of N (paper: −3 dB; 1/N gives −3.01)'
    return Outcome(text, {'rows': rows, 'db_per_doubling': slope}, [fig])


def fig6(cfg: RunConfig) -> Outcome:
    """MC (N = 1000), GLR and thresholded GLR against exact on random pairs sorted by exact."""
    n = cfg.n_runs(full=10_000, quick=500)
    rng = np.random.default_rng(cfg.seed)
    pairs = random_pairs(n, rng)
    exact = score(*pairs, 'exact')
    res = {'mc1000': score(*pairs, 'mc', n_samples=1000, rng=rng), 'glr': score(*pairs, 'glr'),
           'glr_thresholded': score(*pairs, 'glr_thresholded')}
    mae = {k: float(np.mean(np.abs(v - exact))) for k, v in res.items()}
    edges = np.linspace(0.0, 1.0, 11)
    diff = res['glr'] - exact
    bins = []
    for lo, hi in itertools.pairwise(edges):
        sel = (exact >= lo) & ((exact < hi) if hi < 1 else (exact <= hi))
        bins.append({'lo': float(lo), 'hi': float(hi), 'count': int(sel.sum()),
                     'glr_minus_exact': float(diff[sel].mean()) if sel.any() else None})
    # crossover: first sign change (+ → −) of the binned mean, linearly interpolated between bin centres
    centres = [(b['lo'] + b['hi']) / 2 for b in bins if b['glr_minus_exact'] is not None]
    means = [b['glr_minus_exact'] for b in bins if b['glr_minus_exact'] is not None]
    crossover = None
    for k in range(len(means) - 1):
        if means[k] > 0 >= means[k + 1]:
            crossover = float(centres[k] + (centres[k + 1] - centres[k]) * means[k] / (means[k] - means[k + 1]))
            break
    over = [0.0, crossover] if crossover is not None else None
    under = [crossover, 1.0] if crossover is not None else None
    order = np.argsort(exact, kind='stable')
    fig = _fig_path(cfg, 'geo-fig6.png')
    plt = pyplot()
    f, ax = plt.subplots(figsize=(8, 4))
    k = np.arange(n)
    ax.plot(k, res['glr'][order], 'k.', ms=1, alpha=0.4, label='GLR (eq. 71)')
    ax.plot(k, res['mc1000'][order], '.', color='tab:blue', ms=1, alpha=0.4, label='MC N=1000 (eq. 55)')
    ax.plot(k, exact[order], '-', color='tab:red', lw=1.5, label='exact (eq. 49)')
    ax.axhline(0.5, color='tab:green', lw=1, label='threshold 0.5')
    ax.set_xlabel('trial, sorted by exact overlap')
    ax.set_ylabel('score')
    ax.legend(loc='upper left', markerscale=8)
    f.tight_layout()
    f.savefig(fig, dpi=100)
    plt.close(f)
    text = format_table(['exact bin', 'pairs', 'mean GLR − exact'],
                        [[f'[{b["lo"]:.1f}, {b["hi"]:.1f}{"]" if b["hi"] == 1 else ")"}', b['count'],
                          b['glr_minus_exact'] if b['glr_minus_exact'] is not None else '-'] for b in bins])
    text += '\n' + format_table(['method', 'MAE vs exact'], [[k2, v] for k2, v in mae.items()])
    text += (f'\nGLR over-estimates on {over}, under-estimates on {under} (paper: over on [0, 0.7], '
             'under on [0.7, 1])' if crossover is not None else '\nGLR: no + → − crossover found')
    return Outcome(text, {'pairs': n, 'mae': mae, 'glr_over_range': over, 'glr_under_range': under,
                          'crossover': crossover, 'bins': bins,
                          'fraction_exact_zero': float(np.mean(exact == 0.0)),
                          'fraction_exact_one': float(np.mean(exact == 1.0))}, [fig])
