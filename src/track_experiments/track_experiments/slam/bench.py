"""``track-bench cekf``: one known-landmark update of the full EKF against the Compressed EKF's local
update, for growing maps, and ``cekf_equivalence``: how far the CEKF (after its global update)
is from the full EKF on the same run."""

from __future__ import annotations

import numpy as np

from track_core.slam.cekf import CekfSlam, SlamParams
from track_core.slam.models import observe, vehicle_step
from track_experiments.cli import Outcome, RunConfig, best_time, format_table

# the benchmark's and the equivalence test's filter settings (landmarks scattered on a square, 10 m apart on average)
_BENCH_SLAM = SlamParams(max_range=30.0, local_radius=60.0, local_exit=20.0, sigma_v=0.3, sigma_steer=0.02,
                         sigma_r=0.3, sigma_b=0.01)


def _random_landmarks(n_lm: int, rng: np.random.Generator) -> np.ndarray:
    side = np.sqrt(n_lm) * 10.0
    return rng.uniform(-side / 2, side / 2, (n_lm, 2))


def _random_map_filters(n_lm: int, rng: np.random.Generator):
    """EKF and CEKF with the same n_lm landmarks known a priori (added with one observation each)."""
    lm = _random_landmarks(n_lm, rng)
    pose = np.zeros(3)
    filters = [CekfSlam(pose, np.diag([1e-4] * 3), _BENCH_SLAM, compressed=c) for c in (False, True)]
    z0 = observe(pose, lm)
    for f in filters:
        f.add_landmarks(z0)
        f.global_update()
    return lm, _BENCH_SLAM, filters


def cekf_bench(cfg: RunConfig) -> Outcome:
    rng = np.random.default_rng(cfg.seed)
    rows, out = [], []
    for n_lm in ([50, 200] if cfg.quick else [50, 200, 1000]):
        lm, _, (ekf, cekf) = _random_map_filters(n_lm, rng)
        j = (int(cekf.a_idx[3]) - 3) // 2          # the first active landmark of the CEKF
        z = observe(ekf.pose, lm[j]) + np.array([0.1, 0.0])
        idx_e = np.array([j])
        idx_c = np.array([0])
        Pe = ekf.Paa.copy()

        def upd_e(ekf=ekf, z=z, idx=idx_e, Pe=Pe):
            ekf.Paa[...] = Pe
            ekf.update_known(z, idx)

        def upd_c(cekf=cekf, z=z, idx=idx_c):
            cekf.update_known(z, idx)

        te, tc = best_time(upd_e, repeat=3), best_time(upd_c, repeat=3)
        rows.append([n_lm, te * 1e3, tc * 1e3, te / tc, cekf.n_active_landmarks])
        out.append({'landmarks': n_lm, 'ekf_update_ms': te * 1e3, 'cekf_update_ms': tc * 1e3, 'speedup': te / tc})
    diff = cekf_equivalence(200, 200 if cfg.quick else 1000, cfg.seed)
    table = format_table(['landmarks', 'EKF update ms', 'CEKF local ms', 'speed-up', 'active lm'], rows)
    table += f'\nmax |CEKF − EKF| after {200 if cfg.quick else 1000} steps, 200 landmarks: {diff:.3g}'
    return Outcome(table, {'rows': out, 'max_abs_diff': diff})


def cekf_equivalence(n_lm: int, steps: int, seed: int) -> float:
    """Largest |x| or |P| difference between CEKF (after its global update) and the full EKF."""
    rng = np.random.default_rng(seed)
    lm = _random_landmarks(n_lm, rng)
    pose = np.zeros(3)
    ekf = CekfSlam(pose, np.diag([1e-4] * 3), _BENCH_SLAM, compressed=False)
    cekf = CekfSlam(pose, np.diag([1e-4] * 3), _BENCH_SLAM, compressed=True)
    for k in range(steps):
        u = np.array([3.0, 0.15 * np.sin(k / 60.0)])
        pose = vehicle_step(pose, u, 0.1)
        um = u + rng.normal(0.0, [0.3, 0.02])
        ekf.predict(um, 0.1)
        cekf.predict(um, 0.1)
        zz = observe(pose, lm)
        vis = np.flatnonzero((zz[:, 0] < 30.0) & (zz[:, 1] >= 0) & (zz[:, 1] <= np.pi))
        z = zz[vis] + rng.normal(0.0, [0.3, 0.01], (vis.size, 2))
        ekf.update(z)
        cekf.update(z)   # associates on its own; the tests check it agrees with the EKF's
    xe, Pe = ekf.mean_cov()
    xc, Pc = cekf.mean_cov()
    if xe.shape != xc.shape:
        return float('inf')
    return float(max(np.abs(xe - xc).max(), np.abs(Pe - Pc).max()))
