"""Smoother peers given the filter's own problem: GTSAM iSAM2 and batch Levenberg–Marquardt.

``track-experiment victoria-park-smoother`` runs the hybrid CEKF over Victoria Park as
``victoria-park`` does, records what the filter used, and hands exactly that to GTSAM
(optional: ``pip install -r requirements-bench.txt``; without it the entry reports itself skipped):

- **Poses**: one per scan, at the laser (the filter's state, eq. 5's origin), the first one held by
  a prior equal to the filter's initial pose and covariance.
- **Odometry**: between consecutive scans, the relative pose the CEKF's prediction integrates (the
  same Euler steps of the ACFR model with the same zero-order-hold inputs and the same step times:
  the model is a body-fixed velocity rotated by φ, so integrating it from the identity gives the
  motion in the frame of the earlier pose) and its covariance Q = Σ F Q Fᵀ + G Σᵤ Gᵀ from the
  same input noise, turned into GTSAM's tangent space of the later pose (Ad = diag(Rᵀ(Δφ), 1)).
  A 1e-8 floor on Q's diagonal keeps a stationary interval (rank-one Q) a proper Gaussian.
- **Observations and association**: ``CekfSlam.association_log`` — for every scan the CEKF updated
  with, the observations it fused and the landmark each went to, then the observations that started
  landmarks (a landmark enters the graph at the scan that mapped it, as in the filter; tentative
  sightings before that, and observations between the gates, are in neither). Range–bearing factors
  with the filter's σ_r, σ_b; the eq. 5 bearing (0 = right) becomes GTSAM's (0 = ahead) by − π/2.
  Scans in PF mode carry no association (the PF is association-free), so the smoother sees only their
  odometry there; the PF's hand-over fusion has no counterpart (on Victoria Park: one switch, a few scans).

iSAM2 (relinearisation threshold 0.01, checked every 10 updates as GTSAM's default) takes the graph
scan by scan, each new pose and landmark initialised from its own estimate (previous pose ⊕
odometry, pose ⊕ observation); two of its paths are reported: the final (smoothed) one, and the
online one (each pose's estimate right after the update that added it: what it would have published,
the filter's counterpart). LM optimises the whole graph at once from the filter's path and map
(``--set lm_init=filter``) or from dead reckoning (``lm_init=odometry``). All three paths, and the
filter's online one, are scored by ``victoria.gps_rmse`` (rigid alignment, GPS jumps removed).
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, field

import numpy as np

from track_core.slam import victoria
from track_core.slam.blas import single_threaded_blas
from track_core.slam.cekf import ScanAssociation
from track_core.slam.hybrid import HybridParams, HybridSlam
from track_core.slam.models import InputModel, inverse_observe, vehicle_step_scalar
from track_core.slam.profiles import VICTORIA_PARK
from track_experiments.cli import Outcome, RunConfig, format_table, set_keys

log = logging.getLogger(__name__)

GTSAM_MISSING = 'gtsam is not installed (.venv/bin/pip install -r requirements-bench.txt)'
Q_FLOOR = 1e-8


def gtsam_available() -> bool:
    try:
        import gtsam  # noqa: F401
    except ImportError:
        return False
    return True


@dataclass
class RecordedRun:
    """What the filter used, scan by scan (``record_run``)."""

    t: np.ndarray                 # (S,) scan stamps [s]
    pose: np.ndarray              # (S, 3) the filter's pose after each scan
    cov: np.ndarray               # (S, 3, 3) its covariance
    odom: np.ndarray              # (S-1, 3) motion from scan k to k+1 in the frame of pose k
    odom_cov: np.ndarray          # (S-1, 3, 3) its covariance (same frame, x, y, φ)
    assoc: list                   # S lists of ScanAssociation (none in PF mode, two at most)
    landmarks: np.ndarray         # (L, 2) the filter's final map
    pose0: np.ndarray
    P0: np.ndarray
    sigma_r: float
    sigma_b: float
    events: list = field(default_factory=list)
    runtime: float = 0.0


class _RelativeOdometry:
    """The CEKF's prediction (same Euler steps, batched covariance) integrated from the identity."""

    def __init__(self, vehicle: InputModel, Su: np.ndarray) -> None:
        self.vehicle, self.Su = vehicle, Su
        self.reset()

    def reset(self) -> None:
        self.x = [0.0, 0.0, 0.0]
        self.Q = np.zeros((3, 3))

    def step(self, u: np.ndarray, dt: float) -> None:
        if not dt > 0:
            return
        nx, ny, nph, a, b, g00, g01, g10, g11, g20, g21 = vehicle_step_scalar(
            *self.x, float(u[0]), float(u[1]), float(dt), self.vehicle)
        self.x = [nx, ny, nph]
        F = np.eye(3)
        F[0, 2], F[1, 2] = a, b
        G = np.array([[g00, g01], [g10, g11], [g20, g21]])
        self.Q = F @ self.Q @ F.T + G @ self.Su @ G.T


def record_run(vp: victoria.VictoriaPark, rng: np.random.Generator, hybrid: HybridParams | None = None,
               progress=iter) -> RecordedRun:
    """The ``victoria-park`` filter run (ACFR inputs, ``victoria_park`` profile) with its association and
    odometry recorded for a smoother (module docstring)."""
    prof = VICTORIA_PARK
    pose0, P0 = prof.prior()
    with single_threaded_blas():
        h = HybridSlam(pose0, P0, rng, prof.slam, prof.pf, hybrid or prof.hybrid)
        h.cekf.association_log = log_ = []
        rel = _RelativeOdometry(h.vehicle, np.diag([prof.slam.sigma_v ** 2, prof.slam.sigma_steer ** 2]))
        t_last, u = None, np.zeros(2)
        T, X, C, odom, odom_cov, assoc = [], [], [], [], [], []
        t0 = time.perf_counter()
        for ev in progress(victoria.events(vp)):
            t = ev[1]
            if t_last is not None:
                rel.step(u, t - t_last)
            t_last = t
            if ev[0] == 'input':
                h.process_input(t, ev[2], ev[3])
                u = np.array([ev[2], ev[3]])
                continue
            n_log = len(log_)
            h.process_scan(t, ev[2])
            if T:
                odom.append(np.array(rel.x))
                odom_cov.append(rel.Q.copy())
            rel.reset()
            T.append(t)
            X.append(h.pose.copy())
            C.append(h.pose_cov.copy())
            assoc.append(log_[n_log:])
        runtime = time.perf_counter() - t0
    return RecordedRun(np.array(T), np.array(X), np.array(C), np.array(odom).reshape(-1, 3),
                       np.array(odom_cov).reshape(-1, 3, 3), assoc, h.landmarks(), pose0, P0,
                       prof.slam.sigma_r, prof.slam.sigma_b, list(h.events), runtime)


def _compose(p: np.ndarray, d: np.ndarray) -> np.ndarray:
    c, s = math.cos(p[2]), math.sin(p[2])
    ph = p[2] + d[2]
    return np.array([p[0] + c * d[0] - s * d[1], p[1] + s * d[0] + c * d[1], math.atan2(math.sin(ph), math.cos(ph))])


def dead_reckoning(rec: RecordedRun) -> np.ndarray:
    """The scan poses chained from the recorded odometry alone (S, 3)."""
    out = [rec.pose0.copy()]
    for d in rec.odom:
        out.append(_compose(out[-1], d))
    return np.array(out)


class _Graph:
    """The recorded problem as GTSAM factors, scan by scan."""

    def __init__(self, rec: RecordedRun) -> None:
        import gtsam

        self.g, self.rec = gtsam, rec
        self.X, self.L = gtsam.symbol_shorthand.X, gtsam.symbol_shorthand.L
        self.obs_noise = gtsam.noiseModel.Diagonal.Sigmas(np.array([rec.sigma_b, rec.sigma_r]))

    def odometry_factor(self, k: int):
        """Between X(k) and X(k+1): the recorded motion, its covariance in the later pose's tangent space."""
        g, d, Q = self.g, self.rec.odom[k], self.rec.odom_cov[k]
        c, s = math.cos(d[2]), math.sin(d[2])
        Ad = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
        cov = Ad @ Q @ Ad.T
        cov = 0.5 * (cov + cov.T) + Q_FLOOR * np.eye(3)
        return g.BetweenFactorPose2(self.X(k), self.X(k + 1), g.Pose2(*d), g.noiseModel.Gaussian.Covariance(cov))

    def scan_factors(self, k: int) -> tuple[list, list[tuple[int, np.ndarray]]]:
        """Range–bearing factors of scan k and the (landmark, observation) pairs that start landmarks."""
        g, out, new = self.g, [], []
        for a in self.rec.assoc[k]:
            a: ScanAssociation
            for z, j in zip(np.vstack([a.z, a.z_new]), np.concatenate([a.landmarks, a.new]), strict=True):
                out.append(g.BearingRangeFactor2D(self.X(k), self.L(int(j)), g.Rot2(float(z[1]) - math.pi / 2),
                                                  float(z[0]), self.obs_noise))
            new += [(int(j), z) for z, j in zip(a.z_new, a.new, strict=True)]
        return out, new

    def prior(self):
        g = self.g
        return g.PriorFactorPose2(self.X(0), g.Pose2(*self.rec.pose0), g.noiseModel.Gaussian.Covariance(self.rec.P0))

    def full(self, poses: np.ndarray, landmarks: dict[int, np.ndarray]):
        """The whole graph and initial values (poses (S, 3), landmark number → (2,))."""
        g = self.g
        graph, values = g.NonlinearFactorGraph(), g.Values()
        graph.add(self.prior())
        for k in range(len(self.rec.t)):
            values.insert(self.X(k), g.Pose2(*poses[k]))
            if k:
                graph.add(self.odometry_factor(k - 1))
            for f in self.scan_factors(k)[0]:
                graph.add(f)
        for j, m in landmarks.items():
            values.insert(self.L(j), g.Point2(*m))
        return graph, values

    def poses(self, values) -> np.ndarray:
        out = np.empty((len(self.rec.t), 3))
        for k in range(len(self.rec.t)):
            p = values.atPose2(self.X(k))
            out[k] = p.x(), p.y(), p.theta()
        return out


def _landmarks_from(rec: RecordedRun, poses: np.ndarray) -> dict[int, np.ndarray]:
    """Each landmark placed from the pose of the scan that started it (inverse of eq. 5)."""
    out = {}
    for k, entries in enumerate(rec.assoc):
        for a in entries:
            if a.new.size:
                for j, m in zip(a.new, inverse_observe(poses[k], a.z_new), strict=True):
                    out[int(j)] = m
    return out


def run_isam2(rec: RecordedRun, progress=iter, relinearize_threshold: float = 0.01,
              relinearize_skip: int = 10) -> tuple[np.ndarray, np.ndarray, float]:
    """iSAM2 fed scan by scan (module docstring); (final poses (S, 3), online poses (S, 3): each pose's
    estimate right after the update that added it, runtime [s])."""
    import gtsam

    G = _Graph(rec)
    params = gtsam.ISAM2Params()
    params.setRelinearizeThreshold(relinearize_threshold)
    params.relinearizeSkip = relinearize_skip
    isam = gtsam.ISAM2(params)
    pose = rec.pose0.copy()
    online = np.empty((len(rec.t), 3))
    t0 = time.perf_counter()
    for k in progress(range(len(rec.t))):
        graph, values = gtsam.NonlinearFactorGraph(), gtsam.Values()
        if k == 0:
            graph.add(G.prior())
        else:
            graph.add(G.odometry_factor(k - 1))
            pose = _compose(pose, rec.odom[k - 1])
        values.insert(G.X(k), gtsam.Pose2(*pose))
        factors, new = G.scan_factors(k)
        for f in factors:
            graph.add(f)
        for j, z in new:
            values.insert(G.L(j), gtsam.Point2(*inverse_observe(pose, z[None])[0]))
        isam.update(graph, values)
        p = isam.calculateEstimatePose2(G.X(k))
        pose = online[k] = p.x(), p.y(), p.theta()
        pose = np.asarray(pose)
    for _ in range(3):   # a few extra relinearisation passes at the end, as an offline smoother would
        isam.update()
    est = isam.calculateEstimate()
    return G.poses(est), online, time.perf_counter() - t0


def run_lm(rec: RecordedRun, init: str = 'filter', max_iterations: int = 100) -> tuple[np.ndarray, float, int]:
    """Batch Levenberg–Marquardt over the whole graph; (poses (S, 3), runtime [s], iterations)."""
    import gtsam

    G = _Graph(rec)
    if init == 'filter':
        poses = rec.pose
        lms = {j: rec.landmarks[j] for j in range(rec.landmarks.shape[0])}
    elif init == 'odometry':
        poses = dead_reckoning(rec)
        lms = _landmarks_from(rec, poses)
    else:
        raise ValueError(f"lm_init = {init!r}: must be 'filter' or 'odometry'")
    graph, values = G.full(poses, lms)
    params = gtsam.LevenbergMarquardtParams()
    params.setMaxIterations(max_iterations)
    params.setRelativeErrorTol(1e-8)
    params.setAbsoluteErrorTol(1e-8)
    t0 = time.perf_counter()
    opt = gtsam.LevenbergMarquardtOptimizer(graph, values, params)
    est = opt.optimize()
    return G.poses(est), time.perf_counter() - t0, int(opt.iterations())


def association_counts(rec: RecordedRun) -> dict:
    fused = sum(a.z.shape[0] for e in rec.assoc for a in e)
    started = sum(a.z_new.shape[0] for e in rec.assoc for a in e)
    return {'scans': len(rec.t), 'observations_fused': fused, 'landmarks_started': started,
            'scans_without_association': sum(not e for e in rec.assoc)}


@set_keys(lm_init='filter: LM starts from the filter\'s path and map (default); odometry: from dead reckoning')
def victoria_smoother(cfg: RunConfig) -> Outcome:
    """The filter, iSAM2 and batch LM on the same association, odometry and noise (module docstring);
    ``--quick``: the first ``VP_QUICK_S`` seconds."""
    from track_experiments.slam.experiments import VP_QUICK_S

    lm_init = cfg.choice('lm_init', 'filter', 'odometry')
    if not gtsam_available():
        return Outcome(f'victoria-park-smoother skipped: {GTSAM_MISSING}', {'skipped': GTSAM_MISSING})
    vp = victoria.load(t_max=VP_QUICK_S if cfg.quick else None)
    rec = record_run(vp, np.random.default_rng(cfg.seed),
                     progress=lambda it: cfg.progress(it, desc='filter', mininterval=1.0))
    rmse_f = victoria.gps_rmse(rec.t, rec.pose[:, :2], vp.gps)[0]
    xi, xo, ti = run_isam2(rec, progress=lambda it: cfg.progress(it, desc='iSAM2', mininterval=1.0))
    rmse_i = victoria.gps_rmse(rec.t, xi[:, :2], vp.gps)[0]
    rmse_o = victoria.gps_rmse(rec.t, xo[:, :2], vp.gps)[0]
    xl, tl, it = run_lm(rec, lm_init)
    rmse_l = victoria.gps_rmse(rec.t, xl[:, :2], vp.gps)[0]
    rmse_dr = victoria.gps_rmse(rec.t, dead_reckoning(rec)[:, :2], vp.gps)[0]
    best = min(rmse_i, rmse_l)
    nees = {sg: victoria.gps_nees(rec.t, rec.pose[:, :2], rec.cov, vp.gps, sg) for sg in GPS_SIGMAS}
    data = {'gps_rmse_filter_m': rmse_f, 'gps_rmse_isam2_m': rmse_i, 'gps_rmse_isam2_online_m': rmse_o,
            'gps_rmse_lm_m': rmse_l,
            'gps_rmse_dead_reckoning_m': rmse_dr, 'filter_over_best_smoother': rmse_f / best,
            'lm_init': lm_init, 'lm_iterations': it, 'runtime_filter_s': rec.runtime, 'runtime_isam2_s': ti,
            'runtime_lm_s': tl, 'pf_switches': sum(e.kind == 'to_pf' for e in rec.events),
            'path_diff_isam2_lm_max_m': float(np.hypot(*(xi[:, :2] - xl[:, :2]).T).max()),
            **association_counts(rec),
            'gps_anees_filter': {str(sg): float(n.mean()) for sg, n in nees.items()},
            'gps_nees_over_95pct': {str(sg): float(np.mean(n > CHI2_2_95)) for sg, n in nees.items()},
            'gps_sigma_for_anees_2_m': gps_sigma_for_anees(rec, vp.gps)}
    table = format_table(['estimator (same association, odometry, noise)', 'GPS RMSE [m]', 'runtime [s]'], [
        ['hybrid CEKF (online)', rmse_f, rec.runtime], ['GTSAM iSAM2 (final: smoothed path)', rmse_i, ti],
        ['GTSAM iSAM2 (online: each pose as it was added)', rmse_o, ''],
        [f'GTSAM batch LM (from {lm_init}, {it} iterations)', rmse_l, tl], ['dead reckoning', rmse_dr, '']])
    table += (f'\nfilter / best smoother: {rmse_f / best:.3f} (goal <= 1.05); scans {len(rec.t)}, observations '
              f'fused {data["observations_fused"]}, landmarks {data["landmarks_started"]}, scans without '
              f'association (PF mode) {data["scans_without_association"]}')
    table += '\n' + format_table(['filter position NEES against GPS (2 dof)', 'ANEES', 'share > χ²₂ 95 %'], [
        [f'σ_gps = {sg} m per axis (assumed)', float(n.mean()), float(np.mean(n > CHI2_2_95))]
        for sg, n in nees.items()])
    table += f'\nσ_gps that makes the ANEES 2: {data["gps_sigma_for_anees_2_m"]:.2f} m'
    return Outcome(table, data)


GPS_SIGMAS = (0.5, 1.0, 2.0)
CHI2_2_95 = 5.991


def gps_sigma_for_anees(rec: RecordedRun, gps: np.ndarray, target: float = 2.0) -> float:
    """The per-axis GPS σ for which the filter's position ANEES against GPS equals ``target`` (bisection; the
    ANEES falls as σ grows): the GPS noise the filter's covariance would have to assume to be consistent."""
    lo, hi = 1e-3, 50.0
    for _ in range(50):
        mid = math.sqrt(lo * hi)
        if victoria.gps_nees(rec.t, rec.pose[:, :2], rec.cov, gps, mid).mean() > target:
            lo = mid
        else:
            hi = mid
    return math.sqrt(lo * hi)
