"""``track-bench idsq``: one leader step vs its baselines on the 150 × 250 m field, in the same run.

The belief is a mid-track posterior (step T/2 of a K = 64, 30 % DOA run, seed 0) and the leader
is that step's leader with its real neighbours. Timed with ``best_time``:

- ``leader_step_ms``: ``leader_step`` (diffuse, update, MI over every candidate, encode);
- ``mi_loop_ms``: the same MI over the same candidates with a Python loop over cells
  (``mutual_information_loop``, the deliberately slow baseline);
- ``centralized_step_ms``: ``centralized_step`` with all K = 64 sensors.

The table also shows the vectorised MI alone and the loop/vectorised ratio. Both MI rows use the
handed-off belief; inside ``leader_step`` the MI runs on the diffused posterior, whose acoustic
z-grid is longer when the posterior sits near an acoustic sensor (r_min small), so MI is most of
the leader step. ``norm.cdf`` overhead is ≈ 2/3 of ``acoustic_likelihood``'s time (profiled).
"""

from __future__ import annotations

import numpy as np

from track_core.idsq.mi import mutual_information_loop, neighbour_mi
from track_core.idsq.network import candidates
from track_core.idsq.simulation import Scenario, draw_run, run_idsq
from track_core.idsq.tracker import centralized_step, leader_step
from track_experiments.cli import Outcome, RunConfig, best_time, format_table


def bench(cfg: RunConfig) -> Outcome:
    sc = Scenario(n_sensors=64, doa_fraction=0.3)
    d = draw_run(sc, np.random.SeedSequence(cfg.seed))
    t_mid = sc.n_steps // 2
    res = run_idsq(sc, d, 'mi', snapshot_steps=(t_mid - 1, t_mid))
    belief, _, _ = res.snapshots[t_mid - 1]
    leader, prev = int(res.leaders[t_mid]), int(res.leaders[t_mid - 1])
    p, lay = sc.tracker, d.layout
    z = d.measurement(sc, t_mid, leader)
    zs = d.measurements(sc, t_mid)
    cands = candidates(lay, leader, prev)
    repeat = 3 if cfg.quick else 7
    t_step = best_time(lambda: leader_step(belief, z, leader, lay, p, step=t_mid, previous=prev), repeat)
    t_mi = best_time(lambda: neighbour_mi(belief, lay.positions, lay.is_doa, cands, p), repeat)
    t_loop = best_time(lambda: [mutual_information_loop(belief, lay.positions[k], bool(lay.is_doa[k]), p)
                                for k in cands], repeat, min_time=0.02)
    t_cent = best_time(lambda: centralized_step(belief, zs, lay, p), repeat)
    ms = {'leader_step_ms': 1e3 * t_step, 'mi_loop_ms': 1e3 * t_loop, 'centralized_step_ms': 1e3 * t_cent}
    rows = [['leader step (diffuse+update+MI+encode)', ms['leader_step_ms'], '1'],
            ['MI over candidates, vectorised', 1e3 * t_mi, f'{t_mi / t_step:.2f}'],
            ['MI over candidates, per-cell loop', ms['mi_loop_ms'], f'{t_loop / t_step:.2f}'],
            [f'centralized step, K = {sc.n_sensors}', ms['centralized_step_ms'], f'{t_cent / t_step:.2f}']]
    table = (format_table(['operation', 'ms', '× leader step'], rows)
             + f'\nbelief {belief.size} cells, {cands.size} candidates; loop / vectorised MI = {t_loop / t_mi:.1f}×')
    return Outcome(table, ms)
