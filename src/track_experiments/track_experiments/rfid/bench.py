"""``track-bench rfid``: time of one particle-filter update, ours against a per-particle loop.

One update is what the guidance runs after each MOVE: jitter (eq. 21), motion (eq. 20), weights
(eqs. 22, 15), systematic resampling (eq. 16, forced here so that every timed update includes it)
and the suggested turn (eqs. 23–24). Ours is ``RfidParticleFilter.update`` (numpy, vectorised over
particles) at N = 1000 and N = 100000. The baseline is ``pf.loop_update``: the same update written
particle by particle in Python with a random draw per particle, the way the paper's prototype was
written: four scalar draws per particle and §IV.A.3's "particles taken with replacement" as N
draws, each found by a linear scan of the cumulative weights (O(N²), consistent with the paper's
times growing faster than N). The paper reports 473.9 ms at N = 1000 (Table I), on its own
hardware. All are timed with ``best_time`` in the same run; ``speedup`` = that loop / ours at
N = 1000. The table also shows a tuned pure-Python loop with O(N) systematic resampling
(``math`` floats, no numpy), the fastest a per-particle loop gets. It is not in the JSON.
"""

from __future__ import annotations

import numpy as np

from track_core.rfid.pf import PFParams, RfidParticleFilter, loop_update
from track_core.rfid.phase import PhaseModel
from track_experiments.cli import Outcome, RunConfig, best_time, format_table

DPHI, TURN = -12.0, 0.3   # a plausible step: approaching at ≈ 50°, after a 17° turn
PAPER_N1000_MS = 473.9


def _ours(n: int, seed: int) -> RfidParticleFilter:
    pf = RfidParticleFilter(PFParams(n_particles=n, reinit_factor=None), PhaseModel(), np.random.default_rng(seed))
    pf.update(DPHI, 0.0)
    return pf


def bench(cfg: RunConfig) -> Outcome:
    repeat = 3 if cfg.quick else 5
    t = {}
    for n in (1000, 100_000):
        pf = _ours(n, cfg.seed)
        t[n] = best_time(lambda pf=pf: pf.update(DPHI, TURN, force_resample=True), repeat=repeat)
    params, phase = PFParams(n_particles=1000), PhaseModel()
    ref = _ours(1000, cfg.seed)
    state = {'p': ref.particles.tolist(), 'w': ref.weights.tolist()}
    rng = np.random.default_rng(cfg.seed + 1)

    def loop():
        state['p'], state['w'], _ = loop_update(state['p'], state['w'], DPHI, TURN, params, phase, rng)

    def loop_sys():
        state['p'], state['w'], _ = loop_update(state['p'], state['w'], DPHI, TURN, params, phase, rng,
                                                resampling='systematic')

    t_loop = best_time(loop, repeat=repeat, min_time=0.2)
    t_sys = best_time(loop_sys, repeat=repeat, min_time=0.2)
    data = {'n1000_ms': t[1000] * 1e3, 'n100000_ms': t[100_000] * 1e3, 'loop_n1000_ms': t_loop * 1e3,
            'speedup': t_loop / t[1000]}
    rows = [['ours (numpy, vectorised, systematic)', 1000, data['n1000_ms'], 1.0],
            ['ours (numpy, vectorised, systematic)', 100_000, data['n100000_ms'], '-'],
            ['per-particle loop, multinomial by scan (prototype)', 1000, data['loop_n1000_ms'], data['speedup']],
            ['per-particle loop, systematic (tuned pure Python)', 1000, t_sys * 1e3, t_sys / t[1000]],
            ["paper's prototype (Table I, its hardware)", 1000, PAPER_N1000_MS, PAPER_N1000_MS / data['n1000_ms']]]
    return Outcome(format_table(['implementation', 'N', 'ms/update', 'ours faster by'], rows), data)
