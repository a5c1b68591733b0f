"""``track-bench sonar``: time of one SS-PF step (Algorithm 3) at N = 200 and N = 2000, against
what a user would otherwise write, in the same run, and against the UKF given the same model (the
CV model, and the smart-target model: ``smart_pf_over_ukf`` is the PF's cost in UKF steps):

- FilterPy: one ``UnscentedKalmanFilter`` per particle in a Python loop (predict from the particle
  with a near-zero covariance, i.e. our 'transition' proposal, then update), followed by the
  same numpy sampling, weighting and resampling;
- Stone Soup: ``ParticlePredictor`` with ``KalmanProposal`` (unscented predictor/updater) and
  ``ParticleUpdater`` with systematic resampling, bearing-range measurement model.

Scaling (``data['scaling']``): CPU time of one step of the point-particle 'bootstrap' proposal at
N = 10⁵ … 10⁶ and of the 'rb' proposal at the same N (quick: smaller N), the peak memory traced by
``tracemalloc`` (numpy's buffers: the particles and one step's temporaries) and the least-squares
slope of log time against log N (1 = linear).

Peers are optional (``requirements-bench.txt``); a peer that does not import is reported as
unavailable (null in the JSON). Timings use ``best_time`` on an active-sensor step.
"""

from __future__ import annotations

import logging
import math
import time
import tracemalloc

import numpy as np

from track_core.filters import cholesky_jitter, normalize_log_weights, systematic_resample
from track_core.sonar.models import SensorMode, SonarParams, measure, residual
from track_core.sonar.smart_target import SmartTargetParams
from track_core.sonar.sspf import SSPF, make_tracker
from track_experiments.cli import Outcome, RunConfig, best_time, format_table

log = logging.getLogger(__name__)

X0 = np.array([300.0, 12.25, 300.0, -12.25])
P0 = np.diag([25.0, 1.0, 25.0, 1.0])
Z = np.array([math.atan2(300.0, 300.0), math.hypot(300.0, 300.0)])
OBS = np.zeros(2)


def _ours(n: int, seed: int, proposal: str = 'rb', target_model: SmartTargetParams | None = None) -> SSPF:
    # merge=False: these rows time the mixture itself (repeating one reading would let it merge)
    trk = make_tracker('acpf', SonarParams(n_particles=n), np.random.default_rng(seed), proposal=proposal,
                       target_model=target_model, merge=False)
    trk.initialize(X0, P0)
    trk.step(Z, SensorMode.ACTIVE, OBS)
    return trk


def _filterpy_step_fn(n: int, seed: int):
    try:
        from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter
    except ImportError as exc:
        log.warning('filterpy unavailable: %s', exc)
        return None
    p = SonarParams(n_particles=n)
    F, Q, R = p.F, p.Q, p.R('active')
    rng = np.random.default_rng(seed)
    particles = X0 + rng.standard_normal((n, 4)) @ np.linalg.cholesky(P0).T
    L_Q = np.linalg.cholesky(Q)

    def hx(x):
        return measure(x, OBS, 'active')

    def fx(x, dt):
        return F @ x

    ukfs = []
    for _ in range(n):
        ukf = UnscentedKalmanFilter(dim_x=4, dim_z=2, dt=p.T, hx=hx, fx=fx,
                                    points=MerweScaledSigmaPoints(4, alpha=1.0, beta=2.0, kappa=0.0),
                                    residual_z=residual)
        ukf.Q, ukf.R = Q, R
        ukfs.append(ukf)

    def step():
        nonlocal particles
        xt, Pt = np.empty((n, 4)), np.empty((n, 4, 4))
        for i, ukf in enumerate(ukfs):  # what a user would write: one UKF per particle
            ukf.x = particles[i].copy()
            ukf.P = np.eye(4) * 1e-9
            ukf.predict()
            ukf.update(Z)
            xt[i], Pt[i] = ukf.x, ukf.P
        L = cholesky_jitter(Pt)
        e = rng.standard_normal((n, 4))
        x_new = xt + np.einsum('nij,nj->ni', L, e)
        nu = residual(Z, measure(x_new, OBS, 'active'))
        d = np.linalg.solve(L_Q, (x_new - particles @ F.T).T).T
        log_w = (-0.5 * np.sum(nu**2 / np.diag(R), -1) - 0.5 * np.sum(d * d, -1) + 0.5 * np.sum(e * e, -1)
                 + np.sum(np.log(np.diagonal(L, axis1=-2, axis2=-1)), -1))
        w, _ = normalize_log_weights(log_w)
        particles = x_new[systematic_resample(w, rng)]

    return step


def _stonesoup_step_fn(n: int, seed: int):
    try:
        from datetime import datetime, timedelta

        from stonesoup.models.measurement.nonlinear import CartesianToBearingRange
        from stonesoup.models.transition.linear import CombinedLinearGaussianTransitionModel, ConstantVelocity
        from stonesoup.predictor.kalman import UnscentedKalmanPredictor
        from stonesoup.predictor.particle import ParticlePredictor
        from stonesoup.proposal.simple import KalmanProposal
        from stonesoup.resampler.particle import SystematicResampler
        from stonesoup.types.detection import Detection
        from stonesoup.types.hypothesis import SingleHypothesis
        from stonesoup.types.numeric import Probability
        from stonesoup.types.state import ParticleState, StateVectors
        from stonesoup.updater.kalman import UnscentedKalmanUpdater
        from stonesoup.updater.particle import ParticleUpdater
    except ImportError as exc:
        log.warning('stonesoup unavailable: %s', exc)
        return None
    p = SonarParams(n_particles=n)
    np.random.seed(seed)  # noqa: NPY002 - Stone Soup samples from numpy's global generator
    tm = CombinedLinearGaussianTransitionModel([ConstantVelocity(p.q_s), ConstantVelocity(p.q_s)])
    mm = CartesianToBearingRange(ndim_state=4, mapping=(0, 2),
                                 noise_covar=np.diag([p.sigma_b**2, p.sigma_d**2]))
    proposal = KalmanProposal(UnscentedKalmanPredictor(tm), UnscentedKalmanUpdater(mm))
    predictor = ParticlePredictor(tm, proposal=proposal)
    updater = ParticleUpdater(mm, resampler=SystematicResampler())
    rng = np.random.default_rng(seed)
    t0 = datetime(2009, 1, 1)
    samples = X0 + rng.standard_normal((n, 4)) @ np.linalg.cholesky(P0).T
    state = {'prior': ParticleState(StateVectors(samples.T), weight=np.array([Probability(1 / n)] * n),
                                    timestamp=t0)}
    z_ss = np.array([[math.pi / 2 - Z[0]], [Z[1]]])  # Stone Soup bearing is from the x axis

    def step():
        prior = state['prior']
        ts = prior.timestamp + timedelta(seconds=p.T)
        det = Detection(z_ss, timestamp=ts, measurement_model=mm)
        pred = predictor.predict(prior, timestamp=ts, measurement=det)
        state['prior'] = updater.update(SingleHypothesis(pred, det))

    return step


def _ukf_step_fn(peer: str):
    """One active step of the UKF peer ('ukf': ours from filters/; 'stonesoup-ukf'), or None if unavailable."""
    from track_core.sonar.ukf import make_ukf, stonesoup_available

    if peer == 'stonesoup-ukf' and not stonesoup_available():
        log.warning('stonesoup unavailable')
        return None
    trk = make_ukf('acpf', SonarParams(), peer=peer)
    trk.initialize(X0, P0)

    def step():
        trk.initialize(X0, P0)
        trk.step(Z, SensorMode.ACTIVE, OBS)

    return step


def _smart_ukf_step_fn():
    """One active step of the same-model peer, the Gaussian-sum UKF with the smart-target model, pinging every
    step after ten pings (one component per ping of the quiet period: its largest size)."""
    from track_core.sonar.ukf import make_ukf

    trk = make_ukf('acpf', SonarParams(), peer='gs-ukf', target_model=SmartTargetParams())
    trk.initialize(X0, P0)
    for _ in range(10):
        trk.step(Z, SensorMode.ACTIVE, OBS)
    return lambda: trk.step(Z, SensorMode.ACTIVE, OBS)


def _track_stream(trk):
    """A step function feeding ``trk`` the noise-free active readings of a CV target from X0 (eq. 1),
    one new time step per call, so a tracker can be timed over as many steps as the timer needs."""
    F = SonarParams().F
    state = {'x': X0.copy()}

    def step():
        state['x'] = F @ state['x']
        trk.step(measure(state['x'], OBS, SensorMode.ACTIVE), SensorMode.ACTIVE, OBS)

    return step


def merged_cost(seed: int, repeat: int) -> dict:
    """Cost of the default SS-PF once its mixture has merged into one Gaussian, against one UKF step,
    both stepping through the same stream of readings (no re-initialisation); CPU time, interleaved."""
    from track_core.sonar.ukf import make_ukf

    pf = make_tracker('acpf', SonarParams(), np.random.default_rng(seed))
    pf.initialize(X0, P0)
    pf_step = _track_stream(pf)
    k = 0
    while pf.components > 1 and k < 200:
        pf_step()
        k += 1
    ukf = make_ukf('acpf', SonarParams())
    ukf.initialize(X0, P0)
    ukf_step = _track_stream(ukf)
    # interleaved batches of CPU time, best of each: a busy machine slows both alike
    t_pf = t_ukf = float('inf')
    for _ in range(2 * repeat):
        for fn, which in ((pf_step, 'pf'), (ukf_step, 'ukf')):
            t0 = time.process_time()
            for _ in range(200):
                fn()
            dt = (time.process_time() - t0) / 200
            if which == 'pf':
                t_pf = min(t_pf, dt)
            else:
                t_ukf = min(t_ukf, dt)
    return {'steps_to_merge': k if pf.components == 1 else None, 'merged_ms': t_pf * 1e3, 'ukf_ms': t_ukf * 1e3,
            'merged_over_ukf': t_pf / t_ukf}


# Particle counts of the scaling rows (full run, quick run).
SCALE_N = {'bootstrap': ((100_000, 200_000, 500_000, 1_000_000), (10_000, 30_000, 100_000)),
           'rb': ((100_000, 200_000, 500_000, 1_000_000), (2_000, 10_000))}


def _cpu_time(fn, repeat: int) -> float:
    """CPU seconds of one call (all threads of the process), best of ``repeat`` after a warm-up."""
    fn()
    best = float('inf')
    for _ in range(repeat):
        t0 = time.process_time()
        fn()
        best = min(best, time.process_time() - t0)
    return best


def scaling(proposal: str, ns: tuple[int, ...], seed: int, repeat: int = 3) -> dict:
    """CPU s per active step, peak traced memory (MB, state + one step) and the log-log slope of time in N."""
    rows = []
    for n in ns:
        tracemalloc.start()
        trk = _ours(n, seed, proposal)
        trk.step(Z, SensorMode.ACTIVE, OBS)
        peak_mb = tracemalloc.get_traced_memory()[1] / 1e6
        tracemalloc.stop()
        rows.append({'n': n, 'cpu_s': _cpu_time(lambda trk=trk: trk.step(Z, SensorMode.ACTIVE, OBS), repeat),
                     'peak_mb': peak_mb})
        del trk
    logn, logt = np.log([r['n'] for r in rows]), np.log([r['cpu_s'] for r in rows])
    return {'rows': rows, 'loglog_slope': float(np.polyfit(logn, logt, 1)[0])}


def sonar_benchmark(cfg: RunConfig) -> Outcome:
    """Times per active step: our SS-PF ('rb', the default, and 'transition'), the UKF peers, FilterPy, Stone Soup."""
    repeat = 3 if cfg.quick else 5
    t_ours = {}
    for n in (200, 2000):
        trk = _ours(n, cfg.seed)
        t_ours[n] = best_time(lambda trk=trk: trk.step(Z, SensorMode.ACTIVE, OBS), repeat=repeat)
    trk_t = _ours(200, cfg.seed, 'transition')
    t_transition = best_time(lambda: trk_t.step(Z, SensorMode.ACTIVE, OBS), repeat=repeat)
    t_ukf = best_time(_ukf_step_fn('ukf'), repeat=repeat)
    trk_s = _ours(200, cfg.seed, target_model=SmartTargetParams())
    t_pf_smart = best_time(lambda: trk_s.step(Z, SensorMode.ACTIVE, OBS), repeat=repeat)
    t_ukf_smart = best_time(_smart_ukf_step_fn(), repeat=repeat)
    ss_ukf = _ukf_step_fn('stonesoup-ukf')
    t_ss_ukf = None
    if ss_ukf is not None:
        try:
            t_ss_ukf = best_time(ss_ukf, repeat=repeat)
        except Exception as exc:  # a peer's API change must not break our benchmark
            log.warning('stonesoup UKF step failed: %s', exc)
    fp = _filterpy_step_fn(200, cfg.seed)
    t_fp = best_time(fp, repeat=repeat) if fp is not None else None
    t_ss = None
    ss = _stonesoup_step_fn(200, cfg.seed)
    if ss is not None:
        try:
            t_ss = best_time(ss, repeat=repeat)
        except Exception as exc:  # a peer's API change must not break our benchmark
            log.warning('stonesoup step failed: %s', exc)
    data = {
        'n200_ms': t_ours[200] * 1e3,
        'n2000_ms': t_ours[2000] * 1e3,
        'transition_n200_ms': t_transition * 1e3,
        'ukf_ms': t_ukf * 1e3,
        'smart_n200_ms': t_pf_smart * 1e3,
        'ukf_smart_ms': t_ukf_smart * 1e3,
        'smart_pf_over_ukf': t_pf_smart / t_ukf_smart,
        'stonesoup_ukf_ms': None if t_ss_ukf is None else t_ss_ukf * 1e3,
        'filterpy_loop_n200_ms': None if t_fp is None else t_fp * 1e3,
        'stonesoup_n200_ms': None if t_ss is None else t_ss * 1e3,
        'speedup_vs_filterpy': None if t_fp is None else t_fp / t_ours[200],
        'speedup_vs_stonesoup': None if t_ss is None else t_ss / t_ours[200],
    }

    data['merged'] = merged_cost(cfg.seed, repeat)
    pick = 1 if cfg.quick else 0
    scale = {prop: scaling(prop, SCALE_N[prop][pick], cfg.seed) for prop in ('bootstrap', 'rb')}
    data['scaling'] = scale

    def fmt(v):
        return 'unavailable' if v is None else v

    rows = [['SS-PF step, rb (ours, vectorised)', 200, data['n200_ms'], 1.0],
            ['SS-PF step, rb (ours, vectorised)', 2000, data['n2000_ms'], '-'],
            ['SS-PF step, transition (ours)', 200, data['transition_n200_ms'], '-'],
            ['UKF peer step (ours, filters/)', 1, data['ukf_ms'], '-'],
            ['SS-PF step, rb, smart-target model', 200, data['smart_n200_ms'], '-'],
            ['Gaussian-sum UKF step, smart-target model (same model)', 1, data['ukf_smart_ms'], '-'],
            ['Stone Soup UKF step', 1, fmt(data['stonesoup_ukf_ms']), '-'],
            ['FilterPy UKF per particle (loop)', 200, fmt(data['filterpy_loop_n200_ms']),
             fmt(data['speedup_vs_filterpy'])],
            ['Stone Soup ParticleUpdater + KalmanProposal(UKF)', 200, fmt(data['stonesoup_n200_ms']),
             fmt(data['speedup_vs_stonesoup'])]]
    mg = data['merged']
    rows.append([f'SS-PF step after its mixture merged (step {mg["steps_to_merge"]}), per UKF step', 200,
                 mg['merged_ms'], f'{mg["merged_over_ukf"]:.2f}× UKF ({mg["ukf_ms"]:.3f} ms)'])
    srows = [[prop, r['n'], r['cpu_s'], r['peak_mb'], scale[prop]['loglog_slope']] for prop in scale
             for r in scale[prop]['rows']]
    return Outcome(format_table(['implementation', 'N', 'ms/step', 'ours faster by'], rows)
                   + '\n\nScaling, one active step (CPU s of the process; peak traced memory, state and one step)\n'
                   + format_table(['proposal', 'N', 'CPU s/step', 'peak MB', 'log-log slope'], srows), data)
