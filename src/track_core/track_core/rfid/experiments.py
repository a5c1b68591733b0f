"""``track-experiment rfid-table1``: Table I of the paper, the routes of Fig. 6, the obstacle variant.

Per N ∈ {10, 20, 50, 100, 300, 1000}: M searches (200 in the full run) from 10 m with the worst-case
errors (Section VI). Every N uses the same M run seeds, so the same starts. Reported per N (means
over all M runs; a failed run counts with its ``max_steps`` steps): steps, turns, distance walked,
wall time of one filter update with the suggestion, and the success rate. The paper's values are
printed beside ours.

Written beside the figures:
- ``rfid-fig6-route.png``: one route (N = 100, run 0), drawn like Fig. 6.
- ``rfid-obstacles-route.png``: one route in the obstacle variant (``world.office_obstacles``).
- ``rfid-table1-obstacles.json``: the obstacle variant at N = 100 over the same M seeds.
- ``rfid-table1-variants.json``: N = 10 and 100 with the paper's plain circular mean
  (``suggestion='mean'``) and without the lost-filter re-initialisation, to show what those two
  additions (``pf`` module doc) do.

``--json`` holds exactly ``{"rows": [{particles, steps, turns, distance_m, update_ms, success_rate}]}``.
"""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np

from track_core.cli import Outcome, RunConfig, format_table
from track_core.plotting import pyplot
from track_core.rfid.pf import PFParams
from track_core.rfid.search import SearchOutcome, run_search
from track_core.rfid.world import WorldParams, office_obstacles

PARTICLES = (10, 20, 50, 100, 300, 1000)
# Table I: N → (STEPS, TURNS, DISTANCE m, TIME ms); the paper reports 100 % success everywhere.
PAPER_TABLE1 = {10: (30.0, 35.9, 15.4, 10.4), 20: (29.4, 35.0, 15.0, 11.8), 50: (29.2, 34.5, 15.0, 17.8),
                100: (28.5, 33.2, 14.6, 29.2), 300: (28.3, 33.0, 14.5, 90.7), 1000: (28.0, 32.2, 14.3, 473.9)}
MAX_STEPS = 200


def run_batch(world: WorldParams, pf: PFParams, seeds: list[np.random.SeedSequence],
              max_steps: int = MAX_STEPS, progress=iter) -> list[SearchOutcome]:
    return [run_search(world, pf, np.random.default_rng(s), max_steps) for s in progress(seeds)]


def summarize(runs: list[SearchOutcome]) -> dict:
    """Means over all runs (failures included) and the success rate."""
    upd = [r.update_ms for r in runs if math.isfinite(r.update_ms)]
    return {'steps': float(np.mean([r.steps for r in runs])),
            'turns': float(np.mean([r.turns for r in runs])),
            'distance_m': float(np.mean([r.distance_m for r in runs])),
            'update_ms': float(np.mean(upd)) if upd else math.nan,
            'success_rate': float(np.mean([r.success for r in runs]))}


def table1(cfg: RunConfig) -> Outcome:
    n_runs = cfg.n_runs(full=200, quick=4)
    particles = PARTICLES
    world = WorldParams()
    seeds = np.random.SeedSequence(cfg.seed).spawn(n_runs)
    rows, table_rows, run0 = [], [], {}
    for n in particles:
        pf = PFParams(n_particles=n, beam_width=world.beam_width)
        runs = run_batch(world, pf, seeds, progress=lambda it, n=n: cfg.progress(it, desc=f'rfid N={n}',
                                                                                   total=n_runs))
        run0[n] = runs[0]
        row = {'particles': n, **summarize(runs)}
        rows.append(row)
        ps, pt, pd, pm = PAPER_TABLE1[n]
        table_rows.append([n, f"{row['steps']:.1f}", ps, f"{row['turns']:.1f}", pt, f"{row['distance_m']:.1f}", pd,
                           f"{row['update_ms']:.3f}", pm, f"{100 * row['success_rate']:.1f}", 100.0])
    table = (f'Table I, {n_runs} runs per N from {world.start_distance:g} m, worst-case errors '
             f'(means over all runs; failures count {MAX_STEPS} steps)\n'
             + format_table(['N', 'steps', 'paper', 'turns', 'paper', 'dist m', 'paper', 'update ms', 'paper',
                             'success %', 'paper'], table_rows))

    # obstacle variant at N = 100; the two additions switched off at N = 10 and 100
    pf100 = PFParams(n_particles=100, beam_width=world.beam_width)
    obs_world = replace(world, obstacles=office_obstacles())
    obs_runs = run_batch(obs_world, pf100, seeds, progress=lambda it: cfg.progress(it, desc='rfid obstacles',
                                                                                    total=n_runs))
    obs = {'particles': 100, 'runs': n_runs, **summarize(obs_runs)}
    variants = {}
    for n in (10, 100):
        base = replace(pf100, n_particles=n)
        for name, pf in ((f'N={n} paper circular mean (suggestion=mean)', replace(base, suggestion='mean')),
                         (f'N={n} no re-initialisation (reinit_factor=None)', replace(base, reinit_factor=None))):
            variants[name] = {'particles': n, 'runs': n_runs,
                              **summarize(run_batch(world, pf, seeds, progress=lambda it, name=name: cfg.progress(
                                  it, desc=f'rfid {name[:16]}', total=n_runs)))}
    cfg.out.mkdir(parents=True, exist_ok=True)
    (cfg.out / 'rfid-table1-obstacles.json').write_text(json.dumps(obs, indent=2) + '\n')
    (cfg.out / 'rfid-table1-variants.json').write_text(json.dumps(variants, indent=2) + '\n')
    extra = [['N=100 obstacles (office_obstacles)', *_cells(obs)]] + [[k, *_cells(v)] for k, v in variants.items()]
    table += (f'\n\nVariants, {n_runs} runs, the same seeds\n'
              + format_table(['variant', 'steps', 'turns', 'dist m', 'update ms', 'success %'],
                             [['N=10 default (as Table I)', *_cells(rows[particles.index(10)])],
                              ['N=100 default (as Table I)', *_cells(rows[particles.index(100)])], *extra]))
    figs = [plot_route(run0[100], world, cfg.out / 'rfid-fig6-route.png',
                       'Fig. 6 analogue: route of run 0, N = 100'),
            plot_route(obs_runs[0], obs_world, cfg.out / 'rfid-obstacles-route.png',
                       'Obstacle variant: route of run 0, N = 100')]
    return Outcome(table, {'rows': rows}, figs)


def _cells(s: dict) -> list:
    return [f"{s['steps']:.1f}", f"{s['turns']:.1f}", f"{s['distance_m']:.1f}", f"{s['update_ms']:.3f}",
            f"{100 * s['success_rate']:.1f}"]


def plot_route(run: SearchOutcome, world: WorldParams, path: Path, title: str) -> Path:
    """Fig. 6 style: user positions '+' (black), start 'o' (green), tag '*' (red), obstacles grey."""
    plt = pyplot()
    from matplotlib.patches import Rectangle

    fig, ax = plt.subplots(figsize=(6, 6))
    for r in world.obstacles:
        ax.add_patch(Rectangle((r.xmin, r.ymin), r.xmax - r.xmin, r.ymax - r.ymin, color='0.7'))
    route = run.route
    ax.plot(route[:, 0], route[:, 1], '-', color='0.6', lw=0.8)
    ax.plot(route[:, 0], route[:, 1], 'k+', label='user after each step')
    ax.plot(route[0, 0], route[0, 1], 'go', mfc='none', ms=10, label='start')
    ax.plot(0.0, 0.0, 'r*', ms=12, label='RFID tag')
    pts = np.vstack([route, [[0.0, 0.0]], *[[[r.xmin, r.ymin], [r.xmax, r.ymax]] for r in world.obstacles]])
    (x0, y0), (x1, y1) = pts.min(0), pts.max(0)
    half = 0.5 * max(x1 - x0, y1 - y0) + 1.0
    cx, cy = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
    ax.set_xlim(cx - half, cx + half)
    ax.set_ylim(cy - half, cy + half)
    ax.set_aspect('equal')
    ax.set_xlabel('x (m)')
    ax.set_ylabel('y (m)')
    status = 'found' if run.success else 'not found'
    ax.set_title(f'{title}\n{run.steps} steps, {run.turns} turns, {run.distance_m:.1f} m, {status}')
    ax.legend(loc='best', fontsize=8)
    ax.grid(True, lw=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path
