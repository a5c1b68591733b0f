"""The UKF peer of the SS-PF: one unscented Kalman filter with the same eq. 7 scheduler.

``UKFTracker`` has the interface of ``SSPF`` (``initialize``, ``step``, ``next_mode``,
``estimate``), so ``scenario.run_once`` and the experiments drive both the same way on identical
inputs. Prediction is eqs. 1–4 (``filters.kf_predict``), the update Algorithm 2's unscented
transform (``filters.unscented_update`` with the wrapped bearing residual): it is the RB-UKF of
one particle carrying the whole prior: the SS-PF's ``proposal='rb'`` with ``split=1`` (every particle
the whole prior) equals it to 1e-5 (tested).

Smart-target model (``target_model=SmartTargetParams(...)``, the same model the SS-PF is given).
A single Gaussian carries the continuous state; the discrete part, the time the target last heard a
ping, is a distribution over the recent ping times (after a ping at range r, the target heard it with
P_det(r), averaged over the sigma points of the estimate). The target evades while the last ping it
heard is younger than ``quiet_period``, so the distribution gives two hypotheses, evade and cruise,
each predicted through ``smart_target.evasive_transition`` by its sigma points plus Q (as each SS-PF
particle is; ``prediction='linear'``: the mean moved, F P Fᵀ + Q), updated by the UKF, weighted by
its predictive likelihood N(ν; 0, S) and merged by moment matching (a GPB1 filter;
``filters.mixture_mean_cov``). Both hypotheses cost one batched unscented update. The fair peer of the
SS-PF keeps the hypotheses apart and learns the cruise speed: ``gaussian_sum.GaussianSumUKF``.

``StoneSoupUKF`` wraps Stone Soup's ``UnscentedKalmanPredictor``/``UnscentedKalmanUpdater`` (the
peer the issue compares against) behind the same interface; ``stonesoup_available()`` says whether
it imports (it is an optional bench peer, ``requirements-bench.txt``). Stone Soup measures
bearings counter-clockwise from the x axis, so z_ss = π/2 − z (wrapped) at its boundary.
"""

from __future__ import annotations

import math

import numpy as np

from track_core.filters import (
    check_covariance,
    cv_process_noise,
    cv_transition,
    gaussian_logpdf,
    kf_predict,
    mixture_mean_cov,
    normalize_log_weights,
    sigma_points,
    unscented_predict,
    unscented_update,
    unscented_weights,
    wrap_angle,
)
from track_core.sonar.models import SensorMode, SonarParams, measure, residual
from track_core.sonar.scheduler import DELTA, CovarianceScheduler, FixedScheduler
from track_core.sonar.smart_target import SmartTargetParams, batched_transition, evasive_transition
from track_core.sonar.sspf import PREDICTIONS, TRACKERS, SonarEstimate


def _scheduler(kind: str, params: SonarParams, P_D, delta: float, metric: str, block: str, cov_kind: str):
    if kind == 'ss-pf':
        return CovarianceScheduler(P_D, delta, metric=metric, block=block, cov_kind=cov_kind, params=params)
    if kind == 'papf':
        return FixedScheduler(SensorMode.PASSIVE)
    if kind == 'acpf':
        return FixedScheduler(SensorMode.ACTIVE)
    raise ValueError(f'tracker must be one of {TRACKERS}, got {kind!r}')


class UKFTracker:
    """One UKF (ours, from ``track_core.filters``) with a scheduler; ESS is reported as 1.

    ``target_model``: the smart-target model as two merged hypotheses (module docstring);
    ``p_evade`` is the posterior probability that the target is evading after the last step.
    """

    def __init__(self, params: SonarParams | None = None, scheduler=None, *,
                 target_model: SmartTargetParams | None = None, prediction: str = 'unscented') -> None:
        if prediction not in PREDICTIONS:
            raise ValueError(f'prediction must be one of {PREDICTIONS}, got {prediction!r}')
        self.prediction = prediction
        self.params = params or SonarParams()
        self.scheduler = scheduler if scheduler is not None else CovarianceScheduler(params=self.params)
        self.target_model = target_model
        self._w = unscented_weights(4, self.params.ukf_alpha, self.params.ukf_beta, self.params.ukf_kappa)
        self.x: np.ndarray | None = None
        self.P: np.ndarray | None = None
        self.k = 0
        self.predictions = 0
        self.p_evade = 0.0
        self.estimate: SonarEstimate | None = None

    @property
    def next_mode(self) -> SensorMode:
        return self.scheduler.next_mode

    def initialize(self, mean: np.ndarray, cov: np.ndarray) -> None:
        self.x = np.asarray(mean, dtype=float).copy()
        self.P = check_covariance(cov, 'prior covariance').copy()
        self.k = 0
        self.predictions = 0
        self.p_evade = 0.0
        self._cruise = float(np.hypot(self.x[1], self.x[3]))
        self._heard_t = np.empty(0)  # recent ping times ...
        self._heard_p = np.empty(0)  # ... and P(the last ping the target heard was that one)
        self._prev: tuple[np.ndarray, bool] | None = None  # (observer xy, pinged) of the last step
        self.scheduler.reset()
        self.estimate = None

    def step(self, z: np.ndarray, mode: SensorMode | str, observer_xy: np.ndarray, dt: float | None = None,
             R: np.ndarray | None = None) -> SonarEstimate:
        """``SSPF.step``'s interface: a reading ``z`` over ``dt`` (default T) with its noise ``R`` (default
        Table 1's); the smart-target model takes readings every period with Table 1's noise only."""
        if self.x is None or self.P is None:
            raise RuntimeError('UKFTracker.step called before initialize()')
        mode = SensorMode.parse(mode)
        z = np.atleast_1d(np.asarray(z, dtype=float))
        obs = np.asarray(observer_xy, dtype=float)[:2]
        if self.target_model is None:
            F, Q = self._model(dt)
            x_p, P_p = kf_predict(self.x, self.P, F, Q)
            self.x, self.P, _, _ = unscented_update(x_p, P_p, z, lambda chi: measure(chi, obs, mode),
                                                    self.params.R(mode) if R is None else np.asarray(R, float),
                                                    self._w, residual)
        else:
            if dt is not None or R is not None:
                raise ValueError('the UKF peer with the smart-target model takes a reading every period T only')
            self._step_smart(z, mode, obs)
        self.k += 1
        next_mode = self.scheduler.decide(self.P)
        self.estimate = SonarEstimate(self.k, self.x.copy(), self.P.copy(), mode, next_mode, 1.0)
        return self.estimate

    def predict(self, dt: float | None = None, observer_xy: np.ndarray | None = None) -> SonarEstimate:
        """``SSPF.predict``: a step with no reading, eqs. 1–4 over ``dt`` (CV model only)."""
        if self.x is None or self.P is None:
            raise RuntimeError('UKFTracker.predict called before initialize()')
        if self.target_model is not None:
            raise ValueError('the UKF peer with the smart-target model takes a reading every period T only')
        self.x, self.P = kf_predict(self.x, self.P, *self._model(dt))
        self.k += 1
        self.predictions += 1
        prev = self.estimate
        mode = prev.mode if prev is not None else self.scheduler.next_mode
        self.estimate = SonarEstimate(self.k, self.x.copy(), self.P.copy(), mode, self.scheduler.decide(self.P), 1.0)
        return self.estimate

    def _model(self, dt: float | None) -> tuple[np.ndarray, np.ndarray]:
        """Eqs. 3–4 over ``dt`` (None: the period T)."""
        if dt is None or dt == self.params.T:
            return self.params.F, self.params.Q
        if not (math.isfinite(dt) and dt > 0):
            raise ValueError(f'step interval dt must be a finite number > 0 (s), got {dt!r}')
        return cv_transition(dt), cv_process_noise(dt, self.params.q_s)

    def _step_smart(self, z: np.ndarray, mode: SensorMode, obs: np.ndarray) -> None:
        """Evade/cruise hypotheses from the last-heard distribution, UKF-updated, weighted, merged."""
        tm, T = self.target_model, self.params.T
        t_prev = self.k * T
        prev_obs, pinged = self._prev if self._prev is not None else (obs, False)
        if pinged:
            chi = sigma_points(self.x, self.P, self._w)
            p_det = tm.detection_probability(np.hypot(chi[:, 0] - prev_obs[0], chi[:, 2] - prev_obs[1]))
            pd = float(np.clip(self._w.wm @ p_det, 0.0, tm.p_max))
            self._heard_t = np.r_[self._heard_t, t_prev]
            self._heard_p = np.r_[self._heard_p * (1.0 - pd), pd]
        recent = (t_prev - self._heard_t) < tm.quiet_period
        self._heard_t, self._heard_p = self._heard_t[recent], self._heard_p[recent]
        p_ev = float(np.clip(self._heard_p.sum(), 0.0, 1.0))
        hyp = np.array([e for e, p in ((True, p_ev), (False, 1.0 - p_ev)) if p > 0.0])
        prior = np.where(hyp, p_ev, 1.0 - p_ev)
        x2, cruise = np.broadcast_to(self.x, (hyp.size, 4)), np.full(hyp.size, self._cruise)
        if self.prediction == 'linear':
            mu_p = evasive_transition(x2, hyp, prev_obs, cruise, tm, T)
            P_p = np.broadcast_to(self.params.F @ self.P @ self.params.F.T + self.params.Q, (hyp.size, 4, 4))
        else:
            mu_p, P_p = unscented_predict(x2, np.broadcast_to(self.P, (hyp.size, 4, 4)),
                                          batched_transition(hyp, prev_obs, cruise, tm, T), self.params.Q, self._w)
        x_post, P_post, nu, S = unscented_update(mu_p, P_p, z, lambda chi: measure(chi, obs, mode),
                                                 self.params.R(mode), self._w, residual)
        w, _ = normalize_log_weights(np.log(prior) + gaussian_logpdf(nu, S))
        self.p_evade = float(w[hyp].sum())
        if p_ev > 0.0:
            self._heard_p = self._heard_p * (self.p_evade / p_ev)
        self.x, self.P = mixture_mean_cov(x_post, P_post, w)
        self._prev = (obs.copy(), mode is SensorMode.ACTIVE)


def stonesoup_available() -> bool:
    try:
        import stonesoup  # noqa: F401
    except ImportError:
        return False
    return True


class StoneSoupUKF:
    """Stone Soup 1.x UKF with our scheduler (a peer; needs ``stonesoup``)."""

    def __init__(self, params: SonarParams | None = None, scheduler=None) -> None:
        from stonesoup.models.transition.linear import CombinedLinearGaussianTransitionModel, ConstantVelocity
        from stonesoup.predictor.kalman import UnscentedKalmanPredictor

        self.params = p = params or SonarParams()
        self.scheduler = scheduler if scheduler is not None else CovarianceScheduler(params=p)
        tm = CombinedLinearGaussianTransitionModel([ConstantVelocity(p.q_s), ConstantVelocity(p.q_s)])
        kw = {'alpha': p.ukf_alpha, 'beta': p.ukf_beta, 'kappa': p.ukf_kappa}
        self._predictor = UnscentedKalmanPredictor(tm, **kw)
        self._kw = kw
        self.state = None
        self.k = 0
        self.estimate: SonarEstimate | None = None

    @property
    def next_mode(self) -> SensorMode:
        return self.scheduler.next_mode

    def initialize(self, mean: np.ndarray, cov: np.ndarray) -> None:
        from datetime import datetime

        from stonesoup.types.state import GaussianState

        self.state = GaussianState(np.asarray(mean, float).reshape(4, 1), check_covariance(cov, 'prior covariance'),
                                   timestamp=datetime(2009, 1, 1))
        self.k = 0
        self.scheduler.reset()
        self.estimate = None

    def step(self, z: np.ndarray, mode: SensorMode | str, observer_xy: np.ndarray) -> SonarEstimate:
        from datetime import timedelta

        from stonesoup.models.measurement.nonlinear import Cartesian2DToBearing, CartesianToBearingRange
        from stonesoup.types.angle import Bearing
        from stonesoup.types.detection import Detection
        from stonesoup.types.hypothesis import SingleHypothesis
        from stonesoup.updater.kalman import UnscentedKalmanUpdater

        mode = SensorMode.parse(mode)
        z = np.atleast_1d(np.asarray(z, dtype=float))
        p = self.params
        off = np.array([[observer_xy[0]], [observer_xy[1]]], dtype=float)
        b_ss = float(wrap_angle(math.pi / 2 - z[0]))
        if mode is SensorMode.ACTIVE:
            mm = CartesianToBearingRange(ndim_state=4, mapping=(0, 2), noise_covar=p.R(mode), translation_offset=off)
            zv = np.array([[Bearing(b_ss)], [z[1]]], dtype=object)
        else:
            mm = Cartesian2DToBearing(ndim_state=4, mapping=(0, 2), noise_covar=p.R(mode), translation_offset=off)
            zv = np.array([[Bearing(b_ss)]], dtype=object)
        ts = self.state.timestamp + timedelta(seconds=p.T)
        pred = self._predictor.predict(self.state, timestamp=ts)
        det = Detection(zv, timestamp=ts, measurement_model=mm)
        self.state = UnscentedKalmanUpdater(mm, **self._kw).update(SingleHypothesis(pred, det))
        mean = np.asarray(self.state.state_vector, dtype=float).ravel()
        cov = np.asarray(self.state.covar, dtype=float)
        self.k += 1
        next_mode = self.scheduler.decide(cov)
        self.estimate = SonarEstimate(self.k, mean, cov, mode, next_mode, 1.0)
        return self.estimate


FILTERS = ('pf', 'ukf', 'gs-ukf', 'stonesoup-ukf')


def make_ukf(kind: str, params: SonarParams | None = None, *, peer: str = 'ukf', P_D=None, delta: float = DELTA,
             metric: str = 'spectral', block: str = 'full', cov_kind: str = 'posterior',
             target_model: SmartTargetParams | None = None):
    """'ss-pf'/'papf'/'acpf' scheduling on a UKF: ``peer='ukf'`` (ours), 'gs-ukf' or 'stonesoup-ukf'.

    ``target_model`` gives our UKFs the smart-target model: 'ukf' merges the evade/cruise hypotheses
    into one Gaussian, 'gs-ukf' (``gaussian_sum.GaussianSumUKF``) keeps one UKF per last-heard time;
    Stone Soup's UKF has only eq. 1's CV model.
    """
    p = params or SonarParams()
    sched = _scheduler(kind, p, P_D, delta, metric, block, cov_kind)
    if peer == 'ukf':
        return UKFTracker(p, sched, target_model=target_model)
    if peer == 'gs-ukf':
        from track_core.sonar.gaussian_sum import GaussianSumUKF

        return GaussianSumUKF(p, sched, target_model=target_model)
    if target_model is not None:
        raise ValueError(f"target_model needs peer='ukf' or 'gs-ukf' (ours), got peer={peer!r}")
    if peer == 'stonesoup-ukf':
        return StoneSoupUKF(p, sched)
    raise ValueError(f"peer must be 'ukf', 'gs-ukf' or 'stonesoup-ukf', got {peer!r}")
