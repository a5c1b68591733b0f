"""A Gaussian-sum UKF with the smart-target model: one UKF per hypothesis of when the target last heard a ping.

The fair Gaussian peer of ``SSPF(target_model=...)`` (beyond the paper). The smart target's behaviour
depends on one discrete variable, the time ℓ it last heard a ping (it evades while t − ℓ <
``quiet_period``), so the filter keeps one Gaussian per value of ℓ that still matters: the recent
ping times and 'none or stale' (cruise). ``ukf.UKFTracker(target_model=...)`` merges these into one
Gaussian after every step (GPB1); here each is kept, as the particle filter keeps each particle's own
ℓ, and only the Gaussians with the same ℓ, whose futures are the same, are merged (GPB2-like, at most
one component per ping of the last ``quiet_period`` plus one).

One step, with t the time of the previous step:
1. If the previous step pinged, every component splits into heard (ℓ = t, weight × p) and not heard
   (ℓ kept, weight × (1 − p)), p = P_det(range) averaged over the component's sigma points (the
   particle filter draws it per particle with P_det at the particle's mean).
2. ℓ older than ``quiet_period`` becomes 'stale'; components with the same ℓ are moment-matched
   (``filters.mixture_mean_cov``); weights below ``PRUNE_WEIGHT`` are dropped.
3. Prediction through ``smart_target.evasive_transition`` (the truth's and the particle filter's
   function): ``prediction='unscented'`` (default) passes the component's sigma points through it and
   adds Q, which keeps how the turn away from the observer depends on the position; ``'linear'``
   moves the mean by it with F P Fᵀ + Q, as each 'rb' particle and ``UKFTracker`` do.
4. Unscented update of all components at once; weight × N(ν; 0, S) (eqs. 5–6), normalised.
Output: the mixture's mean and covariance.

The cruise speed c the target returns to is its initial speed, unknown to the filter: with
``cruise='state'`` (default) it is a fifth, constant state, c₀ = |v₀| by the unscented transform of the
prior, learnt through its correlation with the velocity (each PF particle carries the speed of its own
initial mean and selection learns it); ``cruise='prior'`` fixes it to the speed of the prior mean, as
``UKFTracker`` does. Without a target model the filter is the UKF peer.
"""

from __future__ import annotations

import numpy as np

from track_core.filters import (
    check_covariance,
    gaussian_logpdf,
    mixture_mean_cov,
    normalize_log_weights,
    sigma_points,
    symmetrize,
    unscented_predict,
    unscented_update,
    unscented_weights,
)
from track_core.sonar.models import SensorMode, SonarParams, measure, residual
from track_core.sonar.scheduler import CovarianceScheduler
from track_core.sonar.smart_target import SmartTargetParams, evasive_transition
from track_core.sonar.sspf import SonarEstimate

PRUNE_WEIGHT = 1e-6
PREDICTIONS = ('unscented', 'linear')
CRUISE = ('state', 'prior')


class GaussianSumUKF:
    """UKFs, one per last-heard hypothesis, with the interface of ``SSPF`` (``initialize``, ``step``, ``next_mode``).

    ``components`` is the number of Gaussians now; ``p_evade`` the posterior probability of evasion;
    ``cruise_speed`` the estimate of c (the prior mean's speed with ``cruise='prior'``).
    """

    def __init__(self, params: SonarParams | None = None, scheduler=None, *,
                 target_model: SmartTargetParams | None = None, prediction: str = 'unscented',
                 cruise: str = 'state') -> None:
        if prediction not in PREDICTIONS:
            raise ValueError(f'prediction must be one of {PREDICTIONS}, got {prediction!r}')
        if cruise not in CRUISE:
            raise ValueError(f'cruise must be one of {CRUISE}, got {cruise!r}')
        self.params = p = params or SonarParams()
        self.scheduler = scheduler if scheduler is not None else CovarianceScheduler(params=p)
        self.target_model = target_model
        self.prediction = prediction
        self._tm = target_model or SmartTargetParams(naive=True)
        # the augmented state [x, vx, y, vy, c] only where c matters (a smart target)
        self._n = 5 if cruise == 'state' and not self._tm.naive else 4
        self._w4 = unscented_weights(4, p.ukf_alpha, p.ukf_beta, p.ukf_kappa)
        self._w = unscented_weights(self._n, p.ukf_alpha, p.ukf_beta, p.ukf_kappa)
        self._F = np.eye(self._n)
        self._F[:4, :4] = p.F
        self._Q = np.zeros((self._n, self._n))
        self._Q[:4, :4] = p.Q
        self.x: np.ndarray | None = None  # (J, n) component means
        self.k = 0
        self.p_evade = 0.0
        self.estimate: SonarEstimate | None = None

    @property
    def next_mode(self) -> SensorMode:
        return self.scheduler.next_mode

    @property
    def components(self) -> int:
        return 0 if self.x is None else self.x.shape[0]

    @property
    def cruise_speed(self) -> float:
        if self._n == 4:
            return self._cruise
        return float(self.w @ self.x[:, 4])

    def initialize(self, mean: np.ndarray, cov: np.ndarray) -> None:
        mean = np.asarray(mean, dtype=float)
        if mean.shape != (4,) or not np.all(np.isfinite(mean)):
            raise ValueError(f'prior mean must be 4 finite numbers [x, vx, y, vy], got {mean!r}')
        cov = check_covariance(cov, 'prior covariance')
        self._cruise = float(np.hypot(mean[1], mean[3]))
        if self._n == 5:  # c = |v₀| by the unscented transform of the prior
            chi = sigma_points(mean, cov, self._w4)
            c = np.hypot(chi[:, 1], chi[:, 3])
            c_bar = float(self._w4.wm @ c)
            dc = c - c_bar
            cross = self._w4.wc @ ((chi - mean) * dc[:, None])
            mean = np.r_[mean, c_bar]
            cov = np.block([[cov, cross[:, None]], [cross[None], np.array([[self._w4.wc @ dc**2]])]])
        self.x = mean[None].copy()
        self.P = symmetrize(cov)[None].copy()
        self.w = np.ones(1)
        self.heard = np.full(1, -np.inf)  # ℓ per component; -inf: none or stale
        self._prev: tuple[np.ndarray, bool] | None = None
        self.k = 0
        self.p_evade = 0.0
        self.scheduler.reset()
        self.estimate = None

    def step(self, z: np.ndarray, mode: SensorMode | str, observer_xy: np.ndarray) -> SonarEstimate:
        if self.x is None:
            raise RuntimeError('GaussianSumUKF.step called before initialize()')
        mode = SensorMode.parse(mode)
        z = np.atleast_1d(np.asarray(z, dtype=float))
        obs = np.asarray(observer_xy, dtype=float)[:2]
        tm = self._tm
        T, t_prev = self.params.T, self.k * self.params.T
        prev_obs, pinged = self._prev if self._prev is not None else (obs, False)
        if pinged and not tm.naive:
            chi = sigma_points(self.x, self.P, self._w)  # (J, 2n+1, n)
            p = np.clip(tm.detection_probability(np.hypot(chi[..., 0] - prev_obs[0], chi[..., 2] - prev_obs[1]))
                        @ self._w.wm, 0.0, tm.p_max)
            self.x, self.P = np.r_[self.x, self.x], np.r_[self.P, self.P]
            self.w = np.r_[self.w * (1.0 - p), self.w * p]
            self.heard = np.r_[self.heard, np.full(p.size, t_prev)]
        self._regroup(t_prev - self.heard >= tm.quiet_period)
        evading = (t_prev - self.heard) < tm.quiet_period
        mu_p, P_p = self._predict(evading, prev_obs, tm, T)
        x, P, nu, S = unscented_update(mu_p, P_p, z, lambda c: measure(c, obs, mode), self.params.R(mode),
                                       self._w, residual)
        self.w, _ = normalize_log_weights(np.log(self.w) + gaussian_logpdf(nu, S))
        self.x, self.P = x, P
        self.p_evade = float(self.w[evading].sum())
        self._prev = (obs.copy(), mode is SensorMode.ACTIVE)
        mean, cov = mixture_mean_cov(self.x, self.P, self.w)
        mean, cov = mean[:4], cov[:4, :4]
        self.k += 1
        self.estimate = SonarEstimate(self.k, mean, cov, mode, self.scheduler.decide(cov), 1.0)
        return self.estimate

    def _regroup(self, stale: np.ndarray) -> None:
        """Mark stale ℓ, moment-match the components that share ℓ, drop negligible weights."""
        self.heard = np.where(stale, -np.inf, self.heard)
        keys, inv = np.unique(self.heard, return_inverse=True)
        if keys.size < self.heard.size:
            groups = [inv == g for g in range(keys.size)]
            merged = [mixture_mean_cov(self.x[g], self.P[g], self.w[g]) for g in groups]
            self.x, self.P = np.array([m for m, _ in merged]), np.array([C for _, C in merged])
            self.w, self.heard = np.array([self.w[g].sum() for g in groups]), keys
        keep = self.w > PRUNE_WEIGHT * self.w.sum()
        self.x, self.P, self.heard = self.x[keep], self.P[keep], self.heard[keep]
        self.w = self.w[keep] / self.w[keep].sum()

    def _predict(self, evading: np.ndarray, prev_obs: np.ndarray, tm: SmartTargetParams, T: float):
        J = self.x.shape[0]

        def f(x: np.ndarray) -> np.ndarray:  # (..., S, n) or (J, n): each Gaussian's mode, and c
            flat = x.reshape(-1, self._n)
            ev = np.repeat(evading, flat.shape[0] // J)
            c = flat[:, 4] if self._n == 5 else np.full(flat.shape[0], self._cruise)
            y = evasive_transition(flat[:, :4], ev, prev_obs, c, tm, T)
            return (np.c_[y, c] if self._n == 5 else y).reshape(x.shape)

        if self.prediction == 'linear':
            return f(self.x), self._F @ self.P @ self._F.T + self._Q
        return unscented_predict(self.x, self.P, f, self._Q, self._w)
