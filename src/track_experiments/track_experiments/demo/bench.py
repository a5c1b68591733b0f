"""``track-bench kalman``: M constant-velocity trackers updated as one batch against a Python loop
of M single trackers, in the same run."""

from __future__ import annotations

import numpy as np

from track_core.demo.tracker import CVKalmanTracker
from track_experiments.cli import Outcome, RunConfig, best_time, format_table


def kalman_benchmark(cfg: RunConfig) -> Outcome:
    """Batched update of M trackers vs a Python loop over M single trackers."""
    rng = np.random.default_rng(cfg.seed)
    R = np.diag([4.0, 4.0])
    rows, data = [], {}
    for m in ([10, 100] if cfg.quick else [10, 100, 1000]):
        z = rng.normal(size=(m, 2))

        batch = CVKalmanTracker()
        batch.update(0.0, z, R)
        singles = [CVKalmanTracker() for _ in range(m)]
        for i, trk in enumerate(singles):
            trk.update(0.0, z[i], R)
        t = [0.0]

        def step_batch(batch=batch, z=z, t=t):
            t[0] += 0.1
            batch.update(t[0], z, R)

        def step_loop(singles=singles, z=z, t=t):
            t[0] += 0.1
            for i, trk in enumerate(singles):
                trk.update(t[0], z[i], R)

        tb, tl = best_time(step_batch), best_time(step_loop)
        rows.append([m, tb * 1e6, tl * 1e6, tl / tb])
        data[str(m)] = {'batched_us': tb * 1e6, 'loop_us': tl * 1e6, 'speedup': tl / tb}
    table = format_table(['trackers', 'batched µs/step', 'loop µs/step', 'speed-up'], rows)
    return Outcome(table, {'kalman': data})
