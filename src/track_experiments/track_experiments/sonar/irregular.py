"""``track-experiment sonar-irregular``: the SS-PF on contacts as a real sonar gives them, against its peers.

Section 5's target and observer, but the contacts come when they come: intervals drawn uniformly in
[0.3, 1.7] s (mean 1 s, the paper's T), one in ten lost, and nothing at all from 15 s to 25 s. A third of
the contacts are pings (bearing and range), the rest listens (bearing), drawn in advance, so every filter
gets the same contacts and the same navigation. Each filter runs behind the node's
``contacts.ContactSequencer``: a contact is a step over its own interval, a period without one a
predict-only step. Filters, all with the CV model of the truth, on identical inputs:

- ``pf``: our SS-PF (200 Rao-Blackwellised particles, the node's default);
- ``ukf``: the UKF peer (``ukf.UKFTracker``), the SS-PF's best peer given the same model;
- ``reference``: a bootstrap particle filter of 20 000 particles (2 000 with ``--quick``).

Reported: RTAMS over the contact steps, over the predict-only steps of the gap, and the PF − UKF paired
difference of the per-run RMS (mean ± SE); ANEES of the position at the contact steps against its 95 %
band. The truth is eq. 1 on a 0.1 s grid (eqs. 3–4 are exact for any interval), contacts on that grid.
"""

from __future__ import annotations

import numpy as np
from scipy.stats import chi2

from track_core.filters import cv_process_noise, cv_transition
from track_core.metrics import nees_or_nan
from track_core.sonar import ObserverTrajectory, Scenario, SensorMode, SonarParams, make_tracker
from track_core.sonar.contacts import ContactSequencer, Fix, Step, simulated_contact
from track_core.sonar.ukf import make_ukf
from track_experiments.cli import Outcome, RunConfig, format_table
from track_experiments.sonar.experiments import paired_difference

DT_TRUTH = 0.1  # s: the truth's grid
DURATION = 40.0  # s
GAP = (15.0, 25.0)  # s: no contact
LOSS = 0.1  # share of the other contacts lost
ACTIVE = 1.0 / 3.0  # share of pings
INTERVAL = (0.3, 1.7)  # s
REFERENCE_N = 20_000
FILTERS = ('pf', 'ukf', 'reference')
S = 10**9


def contact_plan(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """(grid indices of the contacts on the truth's grid, active flags): the irregular stream."""
    t = np.cumsum(rng.uniform(*INTERVAL, size=int(3 * DURATION)))
    t = t[t <= DURATION]
    keep = ~((t > GAP[0]) & (t < GAP[1])) & (rng.random(t.size) >= LOSS)
    idx = np.unique(np.round(t[keep] / DT_TRUTH).astype(int))
    return idx, rng.random(idx.size) < ACTIVE


def truth_on_grid(sc: Scenario, rng: np.random.Generator) -> np.ndarray:
    """(n + 1, 4) states of eq. 1 every ``DT_TRUTH`` s from the scenario's x₀ (exact discretisation)."""
    n = round(DURATION / DT_TRUTH)
    F, L = cv_transition(DT_TRUTH), np.linalg.cholesky(cv_process_noise(DT_TRUTH, sc.params.q_s))
    w = rng.standard_normal((n, 4)) @ L.T
    x = np.empty((n + 1, 4))
    x[0] = sc.target_x0
    for k in range(n):
        x[k + 1] = F @ x[k] + w[k]
    return x


def run_one(sc: Scenario, tracker, truth: np.ndarray, idx: np.ndarray, active: np.ndarray, prior_mean: np.ndarray,
            noise_seed: np.random.SeedSequence) -> dict:
    """One filter through the sequencer: squared errors and position NEES of its contact and gap steps."""
    tracker.initialize(prior_mean, sc.prior_cov)
    seq = ContactSequencer(tracker, round(sc.params.T * S), nav_wait_ns=0, nav_max_age_ns=S)
    rng = np.random.default_rng(noise_seed)
    steps: list[Step] = []
    for i, on in zip(idx.tolist(), active.tolist(), strict=True):
        key = round(i * DT_TRUTH * S)
        state = sc.observer.state(i * DT_TRUTH)
        seq.add_fix(Fix(key, state[[0, 2]], state[[1, 3]], 0.0), key)
        mode = SensorMode.ACTIVE if on else SensorMode.PASSIVE
        steps += [s for s in seq.add_contact(simulated_contact(rng, key, truth[i], state[[0, 2]], mode, sc.params),
                                             key) if isinstance(s, Step)]
    keys = np.array([s.key for s in steps])
    x_true = truth[np.round(keys / (DT_TRUTH * S)).astype(int)]
    d = np.array([(s.estimate.mean - x)[[0, 2]] for s, x in zip(steps, x_true, strict=True)])
    P = np.array([s.estimate.cov[np.ix_([0, 2], [0, 2])] for s in steps])
    nees, _ = nees_or_nan(d, P)
    update = np.array([s.contact is not None for s in steps])
    return {'err2': np.sum(d * d, axis=1), 'nees': nees, 'update': update}


def run(n_runs: int, seed: int, n_ref: int = REFERENCE_N, progress=iter) -> dict:
    """Per filter, per run: the dicts of ``run_one`` on the same truths, contacts and noise."""
    sc = Scenario(observer=ObserverTrajectory())
    out = {f: [] for f in FILTERS}
    for child in progress(np.random.SeedSequence(seed).spawn(n_runs)):
        s_truth, s_plan, s_noise, s_pf, s_ref = child.spawn(5)
        r_truth = np.random.default_rng(s_truth)
        truth = truth_on_grid(sc, r_truth)
        prior_mean = sc.draw_prior_mean(r_truth, truth[0])
        idx, active = contact_plan(np.random.default_rng(s_plan))
        trackers = {'pf': make_tracker('ss-pf', sc.params, np.random.default_rng(s_pf)),
                    'ukf': make_ukf('ss-pf', sc.params),
                    'reference': make_tracker('ss-pf', SonarParams(n_particles=n_ref), np.random.default_rng(s_ref),
                                              proposal='bootstrap')}
        for name, trk in trackers.items():
            out[name].append(run_one(sc, trk, truth, idx, active, prior_mean, s_noise))
    return out


def irregular(cfg: RunConfig) -> Outcome:
    """The SS-PF, its UKF peer and a large bootstrap reference on the same irregular contacts with a gap."""
    n_runs = cfg.n_runs(full=100, quick=4)
    n_ref = 2_000 if cfg.quick else REFERENCE_N
    res = run(n_runs, cfg.seed, n_ref, progress=lambda it: cfg.progress(it, desc='sonar-irregular', total=n_runs))
    data: dict = {'runs': n_runs, 'reference_particles': n_ref, 'filters': {}}
    rows = []
    for name in FILTERS:
        runs = res[name]
        upd = np.concatenate([r['err2'][r['update']] for r in runs])
        gap = np.concatenate([r['err2'][~r['update']] for r in runs])
        nees = np.concatenate([r['nees'][r['update']] for r in runs])
        m = int(np.isfinite(nees).sum())
        lo, hi = (float(v) for v in chi2.ppf([0.025, 0.975], 2 * m) / m)
        anees = float(np.nanmean(nees))
        row = {'rtams_contacts_m': float(np.sqrt(upd.mean())), 'rtams_gap_m': float(np.sqrt(gap.mean())),
               'anees_position': anees, 'band_95': [lo, hi], 'in_band': bool(lo <= anees <= hi),
               'contacts_per_run': float(np.mean([r['update'].sum() for r in runs])),
               'predict_only_per_run': float(np.mean([(~r['update']).sum() for r in runs]))}
        data['filters'][name] = row
        rows.append([name, row['rtams_contacts_m'], row['rtams_gap_m'], anees, f'[{lo:.2f}, {hi:.2f}]'])
    per_run = {n: np.array([np.sqrt(r['err2'].mean()) for r in res[n]]) for n in FILTERS}
    for a, b in (('pf', 'ukf'), ('pf', 'reference')):
        d, se = paired_difference(per_run[a][:, None] ** 2, per_run[b][:, None] ** 2)
        data[f'{a}_minus_{b}_rms_m'], data[f'{a}_minus_{b}_se_m'] = d, se
    f = data['filters']['pf']
    table = (f"{n_runs} runs, Section 5's target and observer; {f['contacts_per_run']:.1f} contacts a run at irregular "
             f"times (a third pings), {f['predict_only_per_run']:.1f} predict-only steps (a 10 s gap, 10 % lost); "
             'every filter on the same contacts, CV model\n'
             + format_table(['filter', 'RTAMS at contacts m', 'RTAMS in the gap m', 'position ANEES', '95 % band'],
                            rows)
             + f"\nPF − UKF per-run RMS: {data['pf_minus_ukf_rms_m']:+.2f} ± {data['pf_minus_ukf_se_m']:.2f} m; "
             f"PF − reference: {data['pf_minus_reference_rms_m']:+.2f} ± {data['pf_minus_reference_se_m']:.2f} m")
    return Outcome(table, data, [])
