"""``track-experiment`` entries ``slam-loop`` and ``victoria-park``.

slam-loop: M runs of the Fig. 1 world (``sim.LoopWorld``), plain EKF-SLAM with nearest neighbour
against the hybrid, on the same truth and noise. A run *fails* when the final position error exceeds
``FAIL_M`` (3 m; landmarks are 8 m apart). ``error_before_m``: the CEKF's mean error at the scan
that started PF mode; ``error_after_m``: the PF's at convergence (paper: 2.2 → 0.5 m);
``pf_scans_median``: scans in PF mode, the initialising one included; ``scans_discarded``: scans
neither filter used. Consistency: the pose (x, y, φ) NEES at every scan averaged over the runs
(``pose_anees``), its mean and the share of scans inside the 95 % band of an average of M χ²₃ values
(``anees_band``), for both filters. The sim uses ``trigger_on_ambiguity=True``; Victoria Park the
uncertainty rule only.

victoria-park: the whole real run (7230 scans with at least one tree, 61945 inputs, 1549 s) through
``HybridSlam`` with the ``victoria_park`` profile; ``--quick``: the first ``VP_QUICK_S`` = 120 s.
Reported: ``gps_rmse_m`` after ``victoria.gps_rmse``'s rigid alignment (GPS jumps removed),
landmarks, switches to PF mode, ``runtime_s`` of the filter loop and ``duration_s``; the PNG shows
the aligned path, map and GPS, the error with 3σ, and the cost of every scan update. The filter loop
runs with one BLAS thread (``blas.single_threaded_blas``).

``--set inputs=odometry``: the same data as standard drivers give it (``victoria.standard_stream``)
through the ``slam`` node's standard-input path (``odometry.OdometryInputs``; ``--set
motion=increments|twist``); ``inputs=both`` runs both and reports their largest difference. Figures:
docs/results/slam.md.
"""

from __future__ import annotations

import logging
import time
from dataclasses import replace

import numpy as np
from scipy.stats import chi2

from track_core.filters import wrap_angle
from track_core.slam import victoria
from track_core.slam.blas import single_threaded_blas
from track_core.slam.cekf import SlamParams
from track_core.slam.hybrid import HybridParams, HybridSlam
from track_core.slam.landmarks import to_eq5_bearing
from track_core.slam.models import UnicycleParams
from track_core.slam.odometry import OdometryInputs
from track_core.slam.profiles import VICTORIA_PARK, loop_sim
from track_core.slam.sim import LoopWorld, simulate
from track_core.slam.streams import BEARING_TOLERANCE, scan_observations
from track_experiments.cli import Outcome, RunConfig, format_table, set_keys
from track_experiments.plotting import pyplot

log = logging.getLogger(__name__)
FAIL_M = 3.0


def run_loop_once(w: LoopWorld, run, hybrid: bool, rng: np.random.Generator) -> dict:
    """One filter over one simulated run; per-scan error and σ history, PF details."""
    with single_threaded_blas():
        return _run_loop_once(w, run, hybrid, rng)


def _run_loop_once(w: LoopWorld, run, hybrid: bool, rng: np.random.Generator) -> dict:
    prof = loop_sim(w)
    h = HybridSlam(*prof.prior(), rng, prof.slam, prof.pf, replace(prof.hybrid, enabled=hybrid))
    si, hist, before, after, clouds = 0, [], [], [], {}
    for k in range(len(run.t)):
        h.process_input(run.t[k], *run.u_meas[k])
        while si < len(run.scans) and run.scans[si][0] <= run.t[k] + w.dt + 1e-9:
            ts, z, _ = run.scans[si]
            kk = round(ts / w.dt)
            truth = run.truth[kk]
            pre_err = np.linalg.norm(h.pose[:2] - truth[:2])
            n_ev = len(h.events)
            h.process_scan(ts, z)
            si += 1
            for ev in h.events[n_ev:]:
                if ev.kind == 'to_pf':
                    before.append(pre_err)
                    clouds.setdefault('init', h.ctx.init_particles if h.ctx else None)
                    if h.ctx is not None:
                        clouds.setdefault('init_global', h._pf_global(h.ctx.init_particles))
                else:
                    last = h.last_pf
                    after.append(np.linalg.norm(h._pf_global(last.pf._last[0][None], last)[0, :2] - truth[:2]))
                    clouds.setdefault('converged', h._pf_global(last.pf.particles, last))
            e = h.pose - truth
            e[2] = wrap_angle(e[2])
            hist.append((ts, *truth[:2], *h.pose[:2], np.sqrt(h.pose_cov[0, 0]), np.sqrt(h.pose_cov[1, 1]),
                         h.mode == 'PF', float(e @ np.linalg.solve(h.pose_cov, e))))
    H = np.array(hist)
    pf_scans = [e.scans for e in h.events if e.kind in ('to_cekf', 'pf_timeout')]
    return {'hist': H, 'final_err': float(np.hypot(*(H[-1, 3:5] - H[-1, 1:3]))), 'before': before, 'after': after,
            'pf_scans': pf_scans, 'clouds': clouds, 'landmarks': h.landmarks(), 'events': h.events,
            'scans': h.n_scans, 'cekf_scans': h.n_cekf_scans, 'pf_scans_used': h.n_pf_scans}


def scans_discarded(r: dict) -> int:
    """Scans of one run (``run_loop_once``) that neither filter used: all scans minus those the CEKF or the
    PF used, a hand-over scan (used by both) counted once."""
    handovers = sum(e.kind in ('to_cekf', 'pf_timeout') for e in r['events'])
    return int(r['scans'] - (r['cekf_scans'] + r['pf_scans_used'] - handovers))


def anees_band(n_runs: int, dof: int, p: float = 0.95) -> tuple[float, float]:
    """Two-sided ``p`` band of the average NEES of ``n_runs`` consistent runs (χ² with n·dof degrees / n)."""
    lo, hi = chi2.ppf([(1 - p) / 2, (1 + p) / 2], n_runs * dof) / n_runs
    return float(lo), float(hi)


def pose_anees(results: list[dict]) -> tuple[float, float]:
    """Pose (x, y, φ) NEES averaged over the runs at each scan (runs cut to the shortest), then: its mean
    over the scans, and the share of scans whose average lies in the 95 % band (``anees_band``)."""
    m = min(len(r['hist']) for r in results)
    a = np.mean([r['hist'][:m, 8] for r in results], axis=0)
    lo, hi = anees_band(len(results), 3)
    return float(a.mean()), float(np.mean((a >= lo) & (a <= hi)))


def slam_loop(cfg: RunConfig) -> Outcome:
    with single_threaded_blas():
        return _slam_loop(cfg)


def _slam_loop(cfg: RunConfig) -> Outcome:
    n_runs = cfg.n_runs(full=50, quick=4)
    w = LoopWorld()
    res = {'ekf': [], 'hybrid': []}
    for child in cfg.progress(np.random.SeedSequence(cfg.seed).spawn(n_runs), desc='slam-loop', total=n_runs):
        s_truth, s_e, s_h = child.spawn(3)
        run = simulate(w, np.random.default_rng(s_truth))
        res['ekf'].append(run_loop_once(w, run, False, np.random.default_rng(s_e)))
        res['hybrid'].append(run_loop_once(w, run, True, np.random.default_rng(s_h)))
        if len(res['hybrid']) == 1:
            run0 = run
    ekf_fail = float(np.mean([r['final_err'] > FAIL_M for r in res['ekf']]))
    hyb_ok = float(np.mean([r['final_err'] <= FAIL_M for r in res['hybrid']]))
    pf_scans = [s for r in res['hybrid'] for s in r['pf_scans'][:1]]
    before = [b for r in res['hybrid'] for b in r['before'][:1]]
    after = [a for r in res['hybrid'] for a in r['after'][:1]]
    discarded = sum(scans_discarded(r) for r in res['hybrid'])
    anees = {k: pose_anees(res[k]) for k in ('ekf', 'hybrid')}
    band = anees_band(n_runs, 3)
    data = {'ekf_failure_rate': ekf_fail, 'hybrid_success_rate': hyb_ok, 'scans_discarded': discarded,
            'pf_scans_median': float(np.median(pf_scans)) if pf_scans else float('nan'),
            'error_before_m': float(np.mean(before)) if before else float('nan'),
            'error_after_m': float(np.mean(after)) if after else float('nan'),
            'anees_hybrid': anees['hybrid'][0], 'anees_hybrid_in_band': anees['hybrid'][1],
            'anees_ekf': anees['ekf'][0], 'anees_ekf_in_band': anees['ekf'][1], 'anees_band': band}
    table = format_table(['quantity', 'ours', 'paper / target'], [
        ['runs', n_runs, 50], ['EKF failure rate', ekf_fail, '>= 0.5'], ['hybrid success rate', hyb_ok, '>= 0.9'],
        ['PF scans (median)', data['pf_scans_median'], '1 (<= 3)'],
        ['error before PF [m]', data['error_before_m'], 2.2],
        ['error after PF [m]', data['error_after_m'], 0.5], ['scans discarded by the switch', discarded, 0],
        ['pose ANEES hybrid (time mean; share of scans in band)',
         f"{anees['hybrid'][0]:.2f}; {anees['hybrid'][1]:.2f}", f'3 ([{band[0]:.2f}, {band[1]:.2f}])'],
        ['pose ANEES EKF (time mean; share of scans in band)',
         f"{anees['ekf'][0]:.2f}; {anees['ekf'][1]:.2f}", '']])
    figs = _plot_loop(cfg, w, run0, res)
    return Outcome(table, data, figs)



def _plot_loop(cfg: RunConfig, w: LoopWorld, run0, res) -> list:
    plt = pyplot()
    cfg.out.mkdir(parents=True, exist_ok=True)
    figs = []
    # Fig. 4: paths (truth, EKF, hybrid mean over runs of run 0)
    fig, ax = plt.subplots(figsize=(7, 5))
    lm = w.landmarks()
    ax.plot(lm[:, 0], lm[:, 1], 'k*', ms=5, label='landmarks')
    ax.plot(run0.truth[:, 0], run0.truth[:, 1], 'k:', lw=1, label='truth (GPS)')
    for key, st in (('ekf', 'r-'), ('hybrid', 'b-')):
        H = res[key][0]['hist']
        ax.plot(H[:, 3], H[:, 4], st, lw=0.8, label=f'{key} (run 0)')
    ax.set_aspect('equal')
    ax.legend(fontsize=7)
    ax.set_title('slam-loop: paths (Fig. 4)')
    figs.append(cfg.out / 'slam-loop-fig4-paths.png')
    fig.savefig(figs[-1], dpi=100)
    plt.close(fig)
    # Fig. 5: particle clouds at initialisation and at convergence
    r = next((r for r in res['hybrid'] if 'init_global' in r['clouds'] and 'converged' in r['clouds']), None)
    fig, axs = plt.subplots(1, 2, figsize=(10, 4.5))
    for ax, key in zip(axs, ('init_global', 'converged'), strict=True):
        ax.plot(lm[:, 0], lm[:, 1], 'k*', ms=5)
        if r is not None:
            p = r['clouds'][key]
            ax.plot(p[:, 0], p[:, 1], '.', ms=1, alpha=0.4)
        ax.plot(run0.truth[:, 0], run0.truth[:, 1], 'k:', lw=0.8)
        ax.set_xlim(-50, 60)
        ax.set_ylim(-40, 60)
        ax.set_aspect('equal')
        ax.set_title('PF ' + ('initialisation (helix)' if key == 'init_global' else 'after convergence'))
    figs.append(cfg.out / 'slam-loop-fig5-particles.png')
    fig.savefig(figs[-1], dpi=100)
    plt.close(fig)
    # Fig. 6: error and σ history averaged over runs
    fig, ax = plt.subplots(figsize=(8, 3.5))
    for key, c in (('ekf', 'r'), ('hybrid', 'b')):
        n = min(len(r['hist']) for r in res[key])
        Hs = np.stack([r['hist'][:n] for r in res[key]])
        err = np.hypot(Hs[..., 3] - Hs[..., 1], Hs[..., 4] - Hs[..., 2]).mean(0)
        sig = np.hypot(Hs[..., 5], Hs[..., 6]).mean(0)
        ax.plot(Hs[0, :, 0], err, c + '-', lw=1, label=f'{key} |error|')
        ax.plot(Hs[0, :, 0], sig, c + '--', lw=0.8, label=f'{key} σ')
    ax.set_xlabel('t [s]')
    ax.set_ylabel('[m]')
    ax.legend(fontsize=7)
    figs.append(cfg.out / 'slam-loop-fig6-error.png')
    fig.tight_layout()
    fig.savefig(figs[-1], dpi=100)
    plt.close(fig)
    return figs


VP_QUICK_S = 120.0


def run_victoria(vp: victoria.VictoriaPark, rng: np.random.Generator, progress=iter,
                 slam: SlamParams | None = None, hybrid: HybridParams | None = None) -> dict:
    """The hybrid filter over a loaded run (single-threaded BLAS, see ``blas.py``); path, cost, GPS RMSE."""
    with single_threaded_blas():
        h = HybridSlam(*VICTORIA_PARK.prior(), rng, slam or VICTORIA_PARK.slam, VICTORIA_PARK.pf,
                       hybrid or VICTORIA_PARK.hybrid)
        T, X, S, cost = [], [], [], []
        t0 = time.perf_counter()
        for ev in progress(victoria.events(vp)):
            if ev[0] == 'input':
                h.process_input(ev[1], ev[2], ev[3])
            else:
                ts = time.perf_counter()
                h.process_scan(ev[1], ev[2])
                cost.append(time.perf_counter() - ts)
                T.append(ev[1])
                X.append(h.pose[:2])
                S.append(h.pose_cov[:2, :2])
        runtime = time.perf_counter() - t0
    T, X = np.array(T), np.array(X)
    rmse, (R, t), g = victoria.gps_rmse(T, X, vp.gps)
    return {'t': T, 'xy': X, 'cov': np.array(S), 'cost': np.array(cost), 'runtime': runtime, 'rmse': rmse,
            'R': R, 'tr': t, 'gps': g, 'landmarks': h.landmarks(), 'events': h.events, 'filter': h}


def standard_events(sr: victoria.StandardRun, motion: str, bearing_limits: tuple[float, float]) -> list[tuple]:
    """The converted run (``victoria.standard_stream``) as the ``slam`` node with ``input_model: odometry`` and
    ``observations: detections`` feeds its filter: odometry messages through ``odometry.OdometryInputs``
    (``motion``: increments or twist; noise = each message's twist covariance), detections through
    ``landmarks.to_eq5_bearing`` and ``streams.scan_observations``, all in stamp order with the scan first
    at equal stamps (the node's ``StreamMerger``)."""
    oi = OdometryInputs(motion)
    ev = []
    for t, pose, (v, w), c in zip(sr.odom_t, sr.odom_pose, sr.twist, sr.twist_cov, strict=True):
        ev += [(ti, 1, 'input', (vi, wi, ci)) for ti, vi, wi, ci, _ in oi.offer(float(t), pose, v, w, c)]
    for t, d in zip(sr.scan_t, sr.detections, strict=True):
        z, _ = scan_observations(d[:, 0], to_eq5_bearing(d[:, 1] + sr.laser[2]), d[:, 2], bearing_limits,
                                 BEARING_TOLERANCE, False)
        ev.append((float(t), 0, 'scan', z))
    ev.sort(key=lambda e: (e[0], e[1]))
    return ev


def run_victoria_standard(vp: victoria.VictoriaPark, rng: np.random.Generator, motion: str = 'increments',
                          progress=iter) -> dict:
    """``run_victoria`` through the standard inputs: the run converted to odometry + landmark detections
    (``victoria.standard_stream``), the unicycle model with the laser at (a, b) of base_link."""
    sr = victoria.standard_stream(vp)
    with single_threaded_blas():
        h = HybridSlam(*VICTORIA_PARK.prior(), rng, VICTORIA_PARK.slam, VICTORIA_PARK.pf, VICTORIA_PARK.hybrid,
                       vehicle=UnicycleParams(a=sr.laser[0], b=sr.laser[1]))
        T, X = [], []
        t0 = time.perf_counter()
        for t, _, kind, payload in progress(standard_events(sr, motion, h.params.bearing_limits)):
            if kind == 'input':
                h.process_input(t, *payload)
            else:
                h.process_scan(t, payload)
                T.append(t)
                X.append(h.pose.copy())
        runtime = time.perf_counter() - t0
    T, X = np.array(T), np.array(X)
    rmse, _, _ = victoria.gps_rmse(T, X[:, :2], vp.gps)
    return {'t': T, 'pose': X, 'rmse': rmse, 'runtime': runtime, 'landmarks': h.landmarks(), 'events': h.events}


@set_keys(inputs='acfr: encoder + steering into the ACFR model (the default, the published figure); odometry: the run '
                 'converted to Odometry + landmark detections through the standard inputs (unicycle model); both: '
                 'both, with their GPS RMSE and largest path difference',
          motion='with odometry: increments (from the poses, the default) or twist')
def victoria_park(cfg: RunConfig) -> Outcome:
    """The whole Victoria Park run (``--quick``: its first ``VP_QUICK_S`` seconds), see module docstring."""
    inputs = cfg.choice('inputs', 'acfr', 'odometry', 'both')
    motion = cfg.choice('motion', 'increments', 'twist')
    vp = victoria.load(t_max=VP_QUICK_S if cfg.quick else None)
    if inputs == 'odometry':
        s = run_victoria_standard(vp, np.random.default_rng(cfg.seed), motion,
                                  progress=lambda it: cfg.progress(it, desc='victoria-park', mininterval=1.0))
        data = {'gps_rmse_m': s['rmse'], 'landmarks': len(s['landmarks']),
                'pf_switches': sum(e.kind == 'to_pf' for e in s['events']), 'runtime_s': s['runtime'],
                'duration_s': vp.duration}
        return Outcome(format_table(['quantity', 'standard inputs'], [[k, v] for k, v in data.items()]), data)
    r = run_victoria(vp, np.random.default_rng(cfg.seed),
                     progress=lambda it: cfg.progress(it, desc='victoria-park', mininterval=1.0))
    h = r['filter']
    n_sw = sum(e.kind == 'to_pf' for e in r['events'])
    pf_scans = sum(e.scans for e in r['events'] if e.kind in ('to_cekf', 'pf_timeout'))
    data = {'gps_rmse_m': r['rmse'], 'landmarks': len(r['landmarks']), 'pf_switches': n_sw,
            'runtime_s': r['runtime'], 'duration_s': vp.duration}
    table = format_table(['quantity', 'ours', 'target'], [
        ['GPS RMSE (aligned) [m]', r['rmse'], '<= 5'], ['landmarks', data['landmarks'], ''],
        ['PF switches', n_sw, ''], ['scans in PF mode', pf_scans, ''],
        ['scans used by the CEKF / PF / either', f'{h.n_cekf_scans} / {h.n_pf_scans} / {h.n_scans}', ''],
        ['runtime [s]', r['runtime'], f'<= {vp.duration / 10:.1f}'], ['duration [s]', vp.duration, ''],
        ['scans / inputs', f'{r["t"].size} / {vp.inputs.shape[0]}', ''],
        ['GPS fixes used', r['gps'].shape[0], ''],
        ['scan cost median / max [ms]', f'{1e3 * np.median(r["cost"]):.2f} / {1e3 * r["cost"].max():.1f}', '']])
    if inputs == 'both':
        st = run_victoria_standard(vp, np.random.default_rng(cfg.seed), motion,
                                   progress=lambda it: cfg.progress(it, desc='standard inputs', mininterval=1.0))
        diff = np.hypot(*(st['pose'][:, :2] - r['xy']).T) if st['t'].shape == r['t'].shape else np.array([np.inf])
        data.update(gps_rmse_standard_m=st['rmse'], path_diff_max_m=float(diff.max()),
                    landmarks_standard=len(st['landmarks']),
                    pf_switches_standard=sum(e.kind == 'to_pf' for e in st['events']))
        table += '\n' + format_table(['standard inputs (Odometry + detections)', 'value'], [
            ['odometry motion', motion], ['GPS RMSE (aligned) [m]', st['rmse']],
            ['largest path difference to the ACFR input [m]', float(diff.max())],
            ['landmarks', len(st['landmarks'])], ['PF switches', data['pf_switches_standard']]])
    figs = _plot_victoria(cfg, r)
    return Outcome(table, data, figs)


def _plot_victoria(cfg: RunConfig, r: dict) -> list:
    plt = pyplot()
    cfg.out.mkdir(parents=True, exist_ok=True)
    fig, axs = plt.subplots(1, 3, figsize=(17, 5.5), gridspec_kw={'width_ratios': [2, 1.2, 1]})
    ax = axs[0]
    Rm, tr = r['R'], r['tr']
    xy = r['xy'] @ Rm.T + tr
    lm = r['landmarks'] @ Rm.T + tr
    g = r['gps']
    ax.plot(g[:, 1], g[:, 2], 'g.', ms=2, label='GPS (jumps removed)')
    ax.plot(xy[:, 0], xy[:, 1], 'b-', lw=0.7, label='hybrid CEKF path (rigidly aligned)')
    ax.plot(lm[:, 0], lm[:, 1], 'k*', ms=3, label=f'map ({lm.shape[0]} trees)')
    sw = np.array([e.t for e in r['events'] if e.kind == 'to_pf'])
    if sw.size:
        p = np.stack([np.interp(sw, r['t'], xy[:, 0]), np.interp(sw, r['t'], xy[:, 1])], 1)
        ax.plot(p[:, 0], p[:, 1], 'mo', ms=7, mfc='none', label='switch to PF')
    ax.set_aspect('equal')
    ax.legend(fontsize=7)
    ax.set_xlabel('east [m] (GPS frame)')
    ax.set_title(f'Victoria Park: map, path, GPS; RMSE {r["rmse"]:.2f} m')
    ax = axs[1]
    est = np.stack([np.interp(g[:, 0], r['t'], xy[:, 0]), np.interp(g[:, 0], r['t'], xy[:, 1])], 1)
    ax.plot(g[:, 0], np.hypot(*(est - g[:, 1:]).T), 'b.', ms=1.5, label='|estimate − GPS|')
    sig = np.sqrt(np.linalg.eigvalsh(r['cov'])[:, -1])
    ax.plot(r['t'], 3 * sig, 'k-', lw=0.7, label='3σ (largest axis)')
    for t in sw:
        ax.axvline(t, color='m', lw=0.8)
    ax.set_xlabel('t [s]')
    ax.set_ylabel('[m]')
    ax.legend(fontsize=7)
    axs[2].plot(r['t'], 1e3 * r['cost'], '.', ms=1)
    axs[2].set_xlabel('t [s]')
    axs[2].set_ylabel('scan update [ms]')
    axs[2].set_yscale('log')
    fig.tight_layout()
    path = cfg.out / 'victoria-park.png'
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return [path]
