"""The paper's trackers: RB-UKF proposal (Algorithm 2) inside a particle filter with covariance-control
scheduling (Algorithm 3), and the PaPF/AcPF baselines of Section 5.

One ``SSPF`` object holds the whole filter state (particles, their UKF covariances, the scheduler's
next mode, a step counter) and is driven one measurement at a time by ``step(z, mode,
observer_xy)``, so an experiment loop and a ROS node use it the same way. All N particles at once:
(N, 4) means, (N, 4, 4) covariances, (N, 9, 4) sigma points.

Proposal (the paper leaves the particle's covariance open):
- ``'rb'`` (default): each particle is N(mⁱ, Pⁱ) updated by Algorithm 2, weighted by its predictive
  likelihood wⁱ ∝ wⁱ_prev N(νⁱ; 0, Sⁱ); the prior is split, means from N(m₀, (1−b)P₀), Pⁱ = bP₀, b =
  ``split`` (None: min(0.25, (50 m/σ)²)); a wide prior's means come from c(1−b)P₀, c =
  ``prior_inflation``, weighted back. Output Cov = Σ wⁱ (Pⁱ + (mⁱ − m̄)(mⁱ − m̄)ᵀ); ``split=1`` is
  the UKF (``ukf.UKFTracker``). Merge/split (``merge``): near-identical Gaussians become one UKF,
  split again when σ > 0.05 r.
- ``'transition'``: point particles, UKF update of N(F xⁱ, Q) (locally optimal proposal);
  ``'bootstrap'``: eq. 1's N(F xⁱ, Q) weighted by p(z | xⁱ) (Gordon et al. 1993; scales to N = 10⁶);
  ``'propagated'``: each particle carries its UKF covariance (weights degenerate; for comparison).
- ``target_model=SmartTargetParams(...)`` ('rb', beyond the paper): each particle draws whether its
  target heard the ping, P_det(range), and moves by ``smart_target.evasive_transition``.

Selection: systematic resampling at every step (``resample_threshold=None``; a wide 'rb' prior waits
until ESS < N/2, ``WIDE_RESAMPLE_THRESHOLD``), or when ESS < threshold·N. ``regularize`` (default):
a Liu–West move x ← a x + (1−a) x̄ + h L e, h = (4/(N(n+2)))^{1/(n+4)}, a = √(1−h²), L Lᵀ the
cloud's covariance; for 'rb' only after a selection with ESS < ``move_threshold``·N (``moves``). A
point cloud whose covariance is singular is re-spread (``repairs``, ``repaired``). Why each choice:
docs/MODULES.md, "The SS-PF and its proposals"; figures: docs/results/sonar.md.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from track_core.filters import (
    check_covariance,
    cholesky_jitter,
    cv_process_noise,
    cv_transition,
    effective_sample_size,
    gaussian_logpdf,
    kf_predict,
    liu_west_move,
    mixture_mean_cov,
    normalize_log_weights,
    symmetrize,
    systematic_resample,
    unscented_predict,
    unscented_update,
    unscented_weights,
    weighted_mean_cov,
)
from track_core.filters.unscented import UnscentedWeights
from track_core.sonar.models import SensorMode, SonarParams, measure, residual
from track_core.sonar.scheduler import CovarianceScheduler, FixedScheduler, SchedulerConfig
from track_core.sonar.smart_target import SmartTargetParams, batched_transition, evasive_transition

log = logging.getLogger(__name__)

PROPOSALS = ('rb', 'transition', 'propagated', 'bootstrap')
# Smart-target model: each particle's Gaussian predicted through the manoeuvre by its sigma points, or
# its mean moved by it with F P Fᵀ + Q (``SSPF._smart_prediction``).
PREDICTIONS = ('unscented', 'linear')
TRACKERS = ('ss-pf', 'papf', 'acpf')
DEFAULT_SPLIT = 0.25
# Largest position standard deviation (m) of one 'rb' particle at the start (``SSPF.split_for``).
COMPONENT_STD = 50.0
# 'rb', CV model: merge the mixture into one Gaussian when its between-component share of the
# covariance is below MERGE_SHARE in every direction; split it again when its position spread σ
# exceeds SPLIT_RATIO times its range from the observer (``SSPF._merge_or_split``).
MERGE_SHARE = 1e-3
SPLIT_RATIO = 0.05
# A wide prior's means are drawn from PRIOR_INFLATION times their covariance and weighted back.
PRIOR_INFLATION = 2.0
# 'rb', wide prior (default ``resample_threshold``): select only when ESS < this share of N.
WIDE_RESAMPLE_THRESHOLD = 0.5
# 'rb': the Liu–West move runs only after a selection whose ESS was below this share of N.
MOVE_THRESHOLD = 0.5
# A cloud has collapsed when its smallest covariance eigenvalue is below COLLAPSE_RTOL times its
# largest or times the smallest eigenvalue of Q (one step of process noise: a cloud that is
# narrower than that in every direction after the proposal has lost its spread).
COLLAPSE_RTOL = 1e-9


def rb_ukf(
    x: np.ndarray,
    P: np.ndarray,
    z: np.ndarray,
    mode: SensorMode | str,
    observer_xy: np.ndarray,
    params: SonarParams,
    weights: UnscentedWeights | None = None,
    *,
    h: Callable[[np.ndarray], np.ndarray] | None = None,
    R: np.ndarray | None = None,
    F: np.ndarray | None = None,
    Q: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Algorithm 2 for a batch: linear prediction (eqs. 1–4), sigma points, unscented update.

    ``x`` (N, 4), ``P`` (N, 4, 4) or (4, 4); returns (x̃ (N, 4), P̃ (N, 4, 4)). P_u includes the
    measurement noise R (the paper's listing omits it; without R the update is not a UKF).
    ``h``/``R`` replace the sonar model (eq. 5/6 of ``mode``, with a wrapped bearing residual) by
    another measurement function z = h(x) + v, v ~ N(0, R), plain residual; the unit tests use a
    linear h to check that the update is exactly the Kalman update. ``F``/``Q`` replace eqs. 3–4 of
    the period T (a step over another interval).
    """
    mode = SensorMode.parse(mode)
    w = weights or unscented_weights(4, params.ukf_alpha, params.ukf_beta, params.ukf_kappa)
    mu_p, P_p = kf_predict(x, P, params.F if F is None else F, params.Q if Q is None else Q)
    P_p = np.broadcast_to(P_p, (*mu_p.shape[:-1], 4, 4))
    z = np.atleast_1d(np.asarray(z, dtype=float))
    if h is not None:
        if R is None:
            raise ValueError('rb_ukf: a custom measurement function h needs its noise covariance R')
        x_post, P_post, _, _ = unscented_update(mu_p, P_p, z, h, np.asarray(R, dtype=float), w)
        return x_post, P_post
    obs = np.asarray(observer_xy, dtype=float)
    x_post, P_post, _, _ = unscented_update(
        mu_p, P_p, z, lambda chi: measure(chi, obs, mode), params.R(mode) if R is None else R, w, residual)
    return x_post, P_post


def rb_ukf_innovation(x: np.ndarray, P: np.ndarray, z: np.ndarray, mode: SensorMode, observer_xy: np.ndarray,
                      params: SonarParams, weights: UnscentedWeights, *,
                      mu_p: np.ndarray | None = None, P_p: np.ndarray | None = None,
                      F: np.ndarray | None = None, Q: np.ndarray | None = None,
                      R: np.ndarray | None = None) -> tuple[np.ndarray, ...]:
    """``rb_ukf`` that also returns the innovation ν (N, m) and its covariance S = P_u + R (N, m, m).

    ν and S give each Gaussian particle's predictive likelihood N(ν; 0, S), the weight of the
    Rao-Blackwellised ('rb') filter. ``mu_p`` (N, 4) and ``P_p`` (N, 4, 4) replace the predicted mean
    F x and covariance F P Fᵀ + Q (a target model with a commanded manoeuvre); ``F``/``Q`` eqs. 3–4 of
    another interval than T, ``R`` the reading's own noise covariance instead of Table 1's.
    """
    mu_lin, P_lin = kf_predict(x, P, params.F if F is None else F, params.Q if Q is None else Q)
    mu_p = mu_lin if mu_p is None else mu_p
    P_p = P_lin if P_p is None else P_p
    P_p = np.broadcast_to(P_p, (*mu_p.shape[:-1], 4, 4))
    obs = np.asarray(observer_xy, dtype=float)
    return unscented_update(mu_p, P_p, z, lambda chi: measure(chi, obs, mode), params.R(mode) if R is None else R,
                            weights, residual)


@dataclass(frozen=True)
class SonarEstimate:
    """Output of one filter step (Algorithm 3, 'Output')."""

    k: int
    mean: np.ndarray  # (4,) E(x_k)
    cov: np.ndarray  # (4, 4) Cov(x_k), the 1/N sample covariance of the selected particles
    mode: SensorMode  # sensor used at this step
    next_mode: SensorMode  # sensor the scheduler chose for the next step
    ess: float  # effective sample size before the selection step
    repaired: bool = False  # a collapsed cloud was detected at this step and re-spread ('transition' only)


@dataclass(frozen=True)
class SSPFConfig:
    """The settings of ``SSPF`` (module docstring): ``proposal``, selection (``resample_threshold``: None
    = the default rule, else a share of N; ``regularize`` and ``move_threshold``: the Liu–West move),
    the 'rb' prior (``split``: None = by the prior's width; ``prior_inflation``), ``merge``, and the
    smart-target model (``target_model``, None = CV; ``prediction``)."""

    proposal: str = 'rb'
    resample_threshold: float | None = None
    regularize: bool = True
    split: float | None = None
    move_threshold: float = MOVE_THRESHOLD
    merge: bool = True
    prior_inflation: float = PRIOR_INFLATION
    prediction: str = 'unscented'
    target_model: SmartTargetParams | None = None

    def __post_init__(self) -> None:
        if self.prediction not in PREDICTIONS:
            raise ValueError(f'prediction must be one of {PREDICTIONS}, got {self.prediction!r}')
        if not (math.isfinite(self.prior_inflation) and self.prior_inflation >= 1.0):
            raise ValueError(f'prior_inflation must be a finite number >= 1, got {self.prior_inflation!r}')
        if not 0.0 < self.move_threshold <= 1.0:
            raise ValueError(f'move_threshold must be in (0, 1] (fraction of N), got {self.move_threshold!r}')
        if self.target_model is not None and self.proposal != 'rb':
            raise ValueError(f"target_model needs proposal='rb', got proposal={self.proposal!r}")
        if self.split is not None and not 0.0 < self.split <= 1.0:
            raise ValueError(f'split must be in (0, 1] (share of the prior covariance per particle), '
                             f'got {self.split!r}')
        r = self.resample_threshold
        if r is not None and not 0.0 < r <= 1.0:
            raise ValueError(f'resample_threshold must be in (0, 1] (fraction of N), got {r!r}')
        if self.proposal not in PROPOSALS:
            raise ValueError(f'proposal must be one of {PROPOSALS}, got {self.proposal!r}')


class SSPF:
    """Particle filter with RB-UKF proposal and a scheduler (eq. 7 or a fixed sensor), with the settings of
    ``config`` (``SSPFConfig``; ``fields`` override its fields by name).

    ``rng`` is the only randomness; the same seed and inputs reproduce a run bit for bit.
    Call ``initialize(mean, cov)`` (the prior p(x₀)) before the first ``step``.
    """

    def __init__(
        self,
        params: SonarParams | None = None,
        scheduler: CovarianceScheduler | FixedScheduler | None = None,
        rng: np.random.Generator | None = None,
        *,
        config: SSPFConfig | None = None,
        **fields,
    ) -> None:
        config = config or SSPFConfig()
        self.config = c = dataclasses.replace(config, **fields) if fields else config
        self.prediction = c.prediction
        self.prior_inflation = float(c.prior_inflation)
        self.merge = bool(c.merge)
        self.merges = 0
        self.splits = 0
        self.move_threshold = float(c.move_threshold)
        self.moves = 0
        self.moved = False
        self.target_model = c.target_model
        self.split = None if c.split is None else float(c.split)
        self.repairs = 0
        self._resample_option = c.resample_threshold
        self.resample_threshold = 1.0 if c.resample_threshold is None else float(c.resample_threshold)
        self.regularize = c.regularize
        proposal = c.proposal
        self.weights: np.ndarray | None = None
        self.params = params or SonarParams()
        self.scheduler = scheduler if scheduler is not None else CovarianceScheduler()
        self.rng = rng if rng is not None else np.random.default_rng()
        self.proposal = proposal
        self._w = unscented_weights(4, self.params.ukf_alpha, self.params.ukf_beta, self.params.ukf_kappa)
        self._F, self._Q = self.params.F, self.params.Q
        self._L_Q = cholesky_jitter(self._Q)
        self._T_model = (self.params.T, self._F, self._Q, self._L_Q)  # eqs. 3-4 over the period T
        self._dt = self.params.T  # the interval of the step being taken
        self.t = 0.0  # time of the filter state since the prior [s]
        self.predictions = 0  # predict-only steps (no reading)
        self._prior: tuple[np.ndarray, np.ndarray] | None = None
        self.particles: np.ndarray | None = None
        self.P: np.ndarray | None = None
        self.k = 0
        self.estimate: SonarEstimate | None = None

    @property
    def n(self) -> int:
        return self.params.n_particles

    @property
    def next_mode(self) -> SensorMode:
        """The sensor to use for the coming step (ACTIVE before the first step for SS-PF)."""
        return self.scheduler.next_mode

    def initialize(self, mean: np.ndarray, cov: np.ndarray) -> None:
        """Draw N equally weighted particles from p(x₀) = N(mean, cov) and reset the scheduler."""
        mean = np.asarray(mean, dtype=float)
        if mean.shape != (4,) or not np.all(np.isfinite(mean)):
            raise ValueError(f'prior mean must be 4 finite numbers [x, vx, y, vy], got {mean!r}')
        cov = check_covariance(cov, 'prior covariance')
        self.k = 0
        self.t = 0.0
        self.predictions = 0
        self.weights = None
        self.repairs = 0
        self.moves = 0
        self.merges = 0
        self.splits = 0
        if self.proposal == 'rb':
            # N(m₀, P₀) = ∫ N(m; m₀, (1−b)P₀) N(x; m, bP₀) dm: N Gaussian particles N(mⁱ, bP₀).
            b = self.split_for(cov)
            # A wide prior (b < DEFAULT_SPLIT): means drawn from c·(1−b)P₀ and weighted back by
            # N(m; m₀, (1−b)P₀)/N(m; m₀, c(1−b)P₀), so the prior's tails keep particles.
            c = self.prior_inflation if b < DEFAULT_SPLIT else 1.0
            e = self.rng.standard_normal((self.n, 4))
            self.particles = mean + e @ cholesky_jitter(c * (1.0 - b) * cov).T
            if c != 1.0:  # m = m₀ + √c L e: log N(m; m₀, LLᵀ) − log N(m; m₀, cLLᵀ) = −½ (c − 1)|e|² + const
                self.weights, _ = normalize_log_weights(-0.5 * (c - 1.0) * np.sum(e * e, axis=1))
            # A wide prior's weights are carried until ESS < N/2: selecting at once would drop the
            # tail means the inflation placed before any reading could favour them.
            self.resample_threshold = (self._resample_option if self._resample_option is not None
                                       else WIDE_RESAMPLE_THRESHOLD if c != 1.0 else 1.0)
            self.P = np.broadcast_to(b * cov, (self.n, 4, 4)).copy()
            self._prior = None
            self._last_heard = np.full(self.n, -np.inf)  # per particle: time it last heard a ping
            self._cruise = np.hypot(self.particles[:, 1], self.particles[:, 3])
            self._prev: tuple[np.ndarray, bool] | None = None  # (observer xy, pinged) of the last step
        elif self.proposal == 'bootstrap':
            self.particles = mean + self.rng.standard_normal((self.n, 4)) @ cholesky_jitter(cov).T
            self.P = None
            self._prior = None
        else:
            L = cholesky_jitter(cov)
            self.particles = mean + self.rng.standard_normal((self.n, 4)) @ L.T
            self.P = (np.broadcast_to(cov, (self.n, 4, 4)) if self.proposal == 'propagated'
                      else np.zeros((self.n, 4, 4))).copy()
            self._prior = (mean.copy(), cov.copy())
        self.scheduler.reset()
        self.estimate = None

    def split_for(self, cov: np.ndarray) -> float:
        """The share b of a prior covariance each 'rb' particle carries: ``split`` when given, else
        min(DEFAULT_SPLIT, (COMPONENT_STD / σ)²) with σ² the largest position variance of ``cov``."""
        if self.split is not None:
            return self.split
        var = float(np.linalg.eigvalsh(np.asarray(cov, float)[np.ix_([0, 2], [0, 2])])[-1])
        return min(DEFAULT_SPLIT, COMPONENT_STD**2 / var) if var > 0 else DEFAULT_SPLIT

    def initialize_mixture(self, means: np.ndarray, covs: np.ndarray, weights: np.ndarray | None = None) -> None:
        """'rb' only: start from the Gaussian mixture Σ wʲ N(mʲ, Pʲ) (e.g. a two-mode prior).

        Each of the N particles picks a component by systematic resampling of ``weights`` and is a
        Gaussian N(m, bP) with m ~ N(mʲ, (1−b)Pʲ), b = ``split_for(Pʲ)``, like ``initialize`` per
        component but with equal weights (no prior inflation).
        """
        if self.proposal != 'rb':
            raise ValueError(f"initialize_mixture needs proposal='rb', got proposal={self.proposal!r}")
        means = np.atleast_2d(np.asarray(means, dtype=float))
        covs = np.broadcast_to(np.asarray(covs, dtype=float), (means.shape[0], 4, 4))
        if means.shape[1:] != (4,) or not np.all(np.isfinite(means)):
            raise ValueError(f'mixture means must be (J, 4) finite numbers, got shape {means.shape}')
        for c in covs:
            check_covariance(c, 'mixture covariance')
        w = np.full(means.shape[0], 1.0 / means.shape[0]) if weights is None else np.asarray(weights, float)
        if w.shape != (means.shape[0],) or not np.all(w >= 0) or not w.sum() > 0:
            raise ValueError(f'mixture weights must be {means.shape[0]} numbers >= 0 with a positive sum, got {w!r}')
        self.initialize(means[0], covs[0])
        j = systematic_resample(w / w.sum(), self.rng, self.n)
        b = np.array([self.split_for(c) for c in covs])[:, None, None]
        L = cholesky_jitter((1.0 - b) * covs)[j]
        self.particles = means[j] + np.einsum('nij,nj->ni', L, self.rng.standard_normal((self.n, 4)))
        self.P = (b * covs)[j]
        self.weights = None
        self._cruise = np.hypot(self.particles[:, 1], self.particles[:, 3])

    def step(self, z: np.ndarray, mode: SensorMode | str, observer_xy: np.ndarray, dt: float | None = None,
             R: np.ndarray | None = None) -> SonarEstimate:
        """One iteration of Algorithm 3 with the reading ``z`` taken by sensor ``mode`` from ``observer_xy``.

        ``z`` is [bearing] (passive) or [bearing, range] (active), bearing from north in rad. ``dt`` is
        the time since the last step (default: the period T); eqs. 3–4 are the constant-velocity model
        of any interval, so a reading at an irregular time is predicted over its own interval. ``R``
        is the reading's noise covariance (default: Table 1's σ_b, σ_d).
        """
        if self.particles is None:
            raise RuntimeError('SSPF.step called before initialize()')
        mode = SensorMode.parse(mode)
        z = np.atleast_1d(np.asarray(z, dtype=float))
        m = 2 if mode is SensorMode.ACTIVE else 1
        if z.shape != (m,) or not np.all(np.isfinite(z)):
            raise ValueError(f'{mode.value} measurement must be {m} finite number(s), got {z!r}')
        obs = np.asarray(observer_xy, dtype=float)[:2]
        self._use_interval(dt)
        self._R = self.params.R(mode) if R is None else _reading_noise(R, mode)
        if self.proposal == 'rb':
            return self._step_rb(z, mode, obs)
        if self.proposal == 'bootstrap':
            return self._step_bootstrap(z, mode, obs)

        x_new, P_tilde, e, L, log_trans = self._propose(z, mode, obs)

        # w ∝ p(z|x) p(x|x_prev) / q(x); constants common to all particles dropped.
        R = self._R
        nu = residual(z, measure(x_new, obs, mode))
        log_lik = -0.5 * np.sum(nu**2 / np.diag(R), axis=-1)
        log_q = (-0.5 * np.sum(e * e, axis=-1) - np.sum(np.log(np.diagonal(L, axis1=-2, axis2=-1)), axis=-1)
                 - 2.0 * np.log(2.0 * np.pi))
        prev_w = np.full(self.n, 1.0 / self.n) if self.weights is None else self.weights
        w, _ = normalize_log_weights(np.log(prev_w) + log_lik + log_trans - log_q)
        ess = effective_sample_size(w)

        # Selection (systematic resampling every step) and output.
        P_keep = P_tilde if self.proposal == 'propagated' else self.P
        if ess < self.resample_threshold * self.n:
            idx = systematic_resample(w, self.rng)
            self.particles = x_new[idx]
            self.P = P_keep[idx]
            self.weights = None
            mean, cov = weighted_mean_cov(self.particles)
            if self.regularize:
                self.particles = liu_west_move(self.particles, self.rng, mean, cov)
                mean, cov = weighted_mean_cov(self.particles)
        else:
            self.particles, self.P, self.weights = x_new, P_keep, w
            mean, cov = weighted_mean_cov(x_new, w)
        # A selected (equally weighted) cloud that has collapsed: all particles (nearly) identical.
        # Re-spread it with the particles' mean UKF covariance, the spread the proposal had before
        # selection removed it; counted in ``repairs`` and logged. (Carried weights are left alone:
        # moving particles would invalidate them, and ESS ≈ 1 triggers selection at the next step.)
        repaired = self.weights is None and collapsed(cov, self._Q)
        if repaired:
            self.repairs += 1
            P_bar = P_tilde.mean(axis=0)
            self.particles = self.particles + self.rng.standard_normal((self.n, 4)) @ cholesky_jitter(P_bar).T
            mean, cov = weighted_mean_cov(self.particles)
            log.warning('k=%d: particle cloud collapsed (ESS %.2f); re-spread with the UKF covariance',
                        self.k + 1, ess)
        self.k += 1
        self.t += self._dt
        next_mode = self.scheduler.decide(cov)
        self.estimate = SonarEstimate(self.k, mean, cov, mode, next_mode, ess, repaired)
        log.debug('k=%d mode=%s ess=%.1f next=%s', self.k, mode.value, ess, next_mode.value)
        return self.estimate

    def _step_rb(self, z: np.ndarray, mode: SensorMode, obs: np.ndarray) -> SonarEstimate:
        """Rao-Blackwellised step: every particle is a Gaussian N(mⁱ, Pⁱ) updated by Algorithm 2.

        Weight: the predictive likelihood wⁱ ∝ wⁱ_prev N(νⁱ; 0, Sⁱ) (νⁱ, Sⁱ from the UKF, eqs. 5–6),
        i.e. p(z | particle i) with x integrated out instead of sampled. Selection: systematic
        resampling when ESS < threshold·N, then a Liu–West move of the means with the spread of
        the means (keeps the mixture's mean and covariance). Output: mixture moments, eq. of
        Algorithm 3's 'Output' with each particle's Pⁱ added, Cov = Σ wⁱ (Pⁱ + (mⁱ − m̄)(mⁱ − m̄)ᵀ).
        Every Pⁱ is a UKF posterior of a prediction ≥ Q, so Cov ≥ min Pⁱ > 0: no collapse.
        """
        mu_p, P_p = self._smart_prediction(obs) if self.target_model is not None else (None, None)
        x_post, P_post, nu, S = rb_ukf_innovation(self.particles, self.P, z, mode, obs, self.params, self._w,
                                                  mu_p=mu_p, P_p=P_p, F=self._F, Q=self._Q, R=self._R)
        self._prev = (obs.copy(), mode is SensorMode.ACTIVE)
        n = x_post.shape[0]  # N, or 1 while the mixture is merged
        if n == 1 and self.target_model is None:  # merged: one UKF step, no weights
            self.particles, self.P, self.weights = x_post, P_post, None
            mean, cov = x_post[0], P_post[0]
            if self.merge:
                self._merge_or_split(mean, cov, obs)
            self.k += 1
            self.t += self._dt
            self.estimate = SonarEstimate(self.k, mean, cov, mode, self.scheduler.decide(cov), 1.0)
            return self.estimate
        prev_w = np.full(n, 1.0 / n) if self.weights is None else self.weights
        with np.errstate(divide='ignore'):  # a carried weight that underflowed to 0 stays 0
            log_prev = np.log(prev_w)
        w, _ = normalize_log_weights(log_prev + gaussian_logpdf(nu, S))
        ess = effective_sample_size(w)
        self.moved = False
        if n > 1 and ess < self.resample_threshold * n:
            idx = systematic_resample(w, self.rng)
            m, P = x_post[idx], P_post[idx]
            self._last_heard, self._cruise = self._last_heard[idx], self._cruise[idx]
            self.weights = None
            if self.regularize and ess < self.move_threshold * n:
                # Only a degenerate selection needs the move: it shrinks every mean towards the centre.
                m = liu_west_move(m, self.rng)
                self.moved = True
                self.moves += 1
            self.particles, self.P = m, P
        else:
            self.particles, self.P, self.weights = x_post, P_post, (None if n == 1 else w)
        mean, cov = mixture_mean_cov(self.particles, self.P, self.weights)
        if self.merge and self.target_model is None:
            self._merge_or_split(mean, cov, obs)
        self.k += 1
        self.t += self._dt
        next_mode = self.scheduler.decide(cov)
        self.estimate = SonarEstimate(self.k, mean, cov, mode, next_mode, ess)
        log.debug('k=%d mode=%s ess=%.1f next=%s', self.k, mode.value, ess, next_mode.value)
        return self.estimate

    def predict(self, dt: float | None = None, observer_xy: np.ndarray | None = None) -> SonarEstimate:
        """A step with no reading: every particle predicted over ``dt`` (default T), weights unchanged.

        The sensor gave nothing (a lost contact, a late message), so the posterior is the prediction
        of eqs. 1–4 (or of the smart-target model, ``observer_xy`` being where the last ping came from
        when the last step pinged); nothing is selected or moved. The scheduler still decides (eq. 7 on
        the predicted covariance), so the request for the next reading is made at every step. Counted
        in ``predictions``.
        """
        if self.particles is None:
            raise RuntimeError('SSPF.predict called before initialize()')
        self._use_interval(dt)
        F, Q = self._F, self._Q
        if self._prior is not None:  # 'transition'/'propagated' before the first reading: the prior itself
            m0, P0 = self._prior
            self._prior = (F @ m0, F @ P0 @ F.T + Q)
            mean, cov = self._prior
        elif self.proposal == 'rb':
            if self.target_model is not None:
                obs = self._prev[0] if self._prev is not None else np.zeros(2)
                mu_p, P_p = self._smart_prediction(obs if observer_xy is None else np.asarray(observer_xy, float))
                if P_p is None:
                    P_p = kf_predict(self.particles, self.P, F, Q)[1]
                self._prev = (self._prev[0], False) if self._prev is not None else None  # the ping is drawn once
                self.particles, self.P = mu_p, np.asarray(P_p).copy()
            else:
                self.particles, self.P = kf_predict(self.particles, self.P, F, Q)
            mean, cov = mixture_mean_cov(self.particles, self.P, self.weights)
        else:
            n = self.particles.shape[0]
            self.particles = self.particles @ F.T + self.rng.standard_normal((n, 4)) @ self._L_Q.T
            if self.proposal == 'propagated':
                self.P = F @ self.P @ F.T + Q
            mean, cov = weighted_mean_cov(self.particles, self.weights)
        self.k += 1
        self.t += self._dt
        self.predictions += 1
        prev = self.estimate
        mode = prev.mode if prev is not None else self.scheduler.next_mode
        ess = prev.ess if prev is not None else float(self.n)
        self.estimate = SonarEstimate(self.k, mean, cov, mode, self.scheduler.decide(cov), ess)
        return self.estimate

    def _use_interval(self, dt: float | None) -> None:
        """Eqs. 3–4 (F, Q and Q's Cholesky factor) for a step of ``dt`` seconds (None: the period T)."""
        T = self.params.T if dt is None else float(dt)
        if not (math.isfinite(T) and T > 0):
            raise ValueError(f'step interval dt must be a finite number > 0 (s), got {dt!r}')
        if self._T_model[0] == T:
            _, self._F, self._Q, self._L_Q = self._T_model
        else:
            self._F, self._Q = cv_transition(T), cv_process_noise(T, self.params.q_s)
            self._L_Q = cholesky_jitter(self._Q)
        self._dt = T

    @property
    def components(self) -> int:
        """Gaussians the 'rb' filter carries now: N, or 1 while the mixture is merged."""
        return 0 if self.particles is None else self.particles.shape[0]

    def _merge_or_split(self, mean: np.ndarray, cov: np.ndarray, obs: np.ndarray) -> None:
        """Pay for the mixture only while it exists (CV model, 'rb').

        Merge: when the between-component share of the covariance is below ``MERGE_SHARE`` in every
        direction, λmax(Cov⁻¹ B) < MERGE_SHARE with B = Σ wⁱ (mⁱ − m̄)(mⁱ − m̄)ᵀ, the N Gaussians
        are (nearly) one: they are replaced by their moment match N(m̄, Cov), exactly the mixture's
        two moments, and the filter continues as one UKF. Split: a single Gaussian whose position
        spread is wide against its range from the observer, σ/r > ``SPLIT_RATIO`` (σ² the largest
        position variance), is where one UKF linearises badly (a wide bearings-only prior, a long
        passive stretch); it is split again as the prior is, N means from N(m̄, (1−b)Cov), each with
        bCov, b = ``split_for(Cov)``. The merge asks for σ/r below the same ratio, so a merged filter
        does not split at the next step.
        """
        a, c, b = cov[0, 0], cov[2, 2], cov[0, 2]
        var = 0.5 * (a + c) + math.sqrt(0.25 * (a - c) ** 2 + b * b)  # λmax of the position block
        wide = var > SPLIT_RATIO**2 * ((mean[0] - obs[0]) ** 2 + (mean[2] - obs[1]) ** 2)
        if self.components > 1:
            _, B = weighted_mean_cov(self.particles, self.weights)
            share = float(np.max(np.linalg.eigvals(np.linalg.solve(cov, B)).real))
            if share < MERGE_SHARE and not wide:
                self.particles, self.P, self.weights = mean[None].copy(), cov[None].copy(), None
                self._last_heard, self._cruise = self._last_heard[:1], self._cruise[:1]
                self.merges += 1
        elif wide and self.n > 1:
            b = self.split_for(cov)
            self.particles = mean + self.rng.standard_normal((self.n, 4)) @ cholesky_jitter((1.0 - b) * cov).T
            self.P = np.broadcast_to(b * cov, (self.n, 4, 4)).copy()
            self.weights = None
            self._last_heard = np.full(self.n, self._last_heard[0])
            self._cruise = np.hypot(self.particles[:, 1], self.particles[:, 3])
            self.splits += 1

    def _step_bootstrap(self, z: np.ndarray, mode: SensorMode, obs: np.ndarray) -> SonarEstimate:
        """Bootstrap step: point particles drawn from eq. 1's transition, x ~ N(F x_prev, Q), weighted by
        wⁱ ∝ wⁱ_prev p(z | xⁱ) (eqs. 5–6); systematic resampling when ESS < threshold·N; no move.

        O(N) arrays of (N, 4) and (N, m) only (no per-particle covariance or sigma points), so a step
        at N = 10⁶ is a few vectorised passes over 32 MB.
        """
        n = self.particles.shape[0]
        x = self.particles @ self._F.T
        x += self.rng.standard_normal((n, 4)) @ self._L_Q.T
        nu = residual(z, measure(x, obs, mode))
        log_w = -0.5 * (nu * nu) @ (1.0 / np.diag(self._R))
        if self.weights is not None:
            log_w += np.log(self.weights)
        w, _ = normalize_log_weights(log_w)
        ess = effective_sample_size(w)
        if ess < self.resample_threshold * n:
            self.particles, self.weights = x[systematic_resample(w, self.rng)], None
        else:
            self.particles, self.weights = x, w
        mean, cov = weighted_mean_cov(self.particles, self.weights)
        self.k += 1
        self.t += self._dt
        next_mode = self.scheduler.decide(cov)
        self.estimate = SonarEstimate(self.k, mean, cov, mode, next_mode, ess)
        return self.estimate

    def _smart_prediction(self, obs: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        """Predicted Gaussians under the smart-target model (a jump-Markov model, sampled per particle).

        If the last step pinged, each particle draws whether its target heard it, with
        P_det(range of its mean) (``SmartTargetParams.detection_probability``); a particle is evading
        while less than ``quiet_period`` has passed since it last heard one, and moves by
        ``smart_target.evasive_transition`` (cruise: back to its own cruise speed, the speed of its
        mean at the start). The discrete part is sampled, the continuous part stays Gaussian (a
        Rao-Blackwellised jump-Markov filter), so the weight N(ν; 0, S) scores each particle's mode.
        ``prediction='unscented'``: each particle's sigma points go through the manoeuvre (its
        turn and speed change are clipped, so where the commanded heading or speed is reached the
        velocity spread contracts), plus Q; ``'linear'``: its mean moves, with F P Fᵀ + Q (returned
        as None).
        """
        tm = self.target_model
        t_prev = self.t
        prev_obs, pinged = self._prev if self._prev is not None else (obs, False)
        if pinged:
            r = np.hypot(self.particles[:, 0] - prev_obs[0], self.particles[:, 2] - prev_obs[1])
            heard = self.rng.random(self.n) < tm.detection_probability(r)
            self._last_heard = np.where(heard, t_prev, self._last_heard)
        evading = (t_prev - self._last_heard) < tm.quiet_period
        if self.prediction == 'linear':
            return evasive_transition(self.particles, evading, prev_obs, self._cruise, tm, self._dt), None
        f = batched_transition(evading, prev_obs, self._cruise, tm, self._dt)
        return unscented_predict(self.particles, self.P, f, self._Q, self._w)

    def _propose(self, z: np.ndarray, mode: SensorMode, obs: np.ndarray):
        """Draw x ~ q = N(x̃ⁱ, P̃ⁱ) (Algorithm 3) and return it with the pieces the weights need."""
        x_prev = self.particles
        if self._prior is not None:
            # First step: the prior is Gaussian and the dynamics linear, so p(x₁) = N(F m₀, F P₀ Fᵀ + Q)
            # exactly; one RB-UKF on the whole prior gives the proposal for all N particles.
            m0, P0 = self._prior
            self._prior = None
            x_tilde, P_tilde = rb_ukf(m0[None], P0[None], z, mode, obs, self.params, self._w, R=self._R,
                                      F=self._F, Q=self._Q)
            L = cholesky_jitter(P_tilde)
            e = self.rng.standard_normal((self.n, 4))
            x_new = x_tilde + e @ L[0].T
            P_tilde = np.broadcast_to(P_tilde, (self.n, 4, 4))
            L = np.broadcast_to(L, (self.n, 4, 4))
            m_p = self._F @ m0
            log_trans = gaussian_logpdf(x_new - m_p, self._F @ P0 @ self._F.T + self._Q)
        else:
            # RB-UKF per particle (all at once), then x ~ N(x̃, P̃).
            x_tilde, P_tilde = rb_ukf(x_prev, self.P, z, mode, obs, self.params, self._w, R=self._R,
                                      F=self._F, Q=self._Q)
            L = cholesky_jitter(P_tilde)
            e = self.rng.standard_normal((self.n, 4))
            x_new = x_tilde + np.einsum('nij,nj->ni', L, e)
            d = x_new - x_prev @ self._F.T
            u = np.linalg.solve(self._L_Q, d.T).T
            log_trans = (-0.5 * np.sum(u * u, axis=-1) - np.sum(np.log(np.diagonal(self._L_Q)))
                         - 2.0 * np.log(2.0 * np.pi))

        return x_new, P_tilde, e, L, log_trans


def _reading_noise(R: np.ndarray, mode: SensorMode) -> np.ndarray:
    """A reading's own noise covariance, checked: (1, 1) passive or (2, 2) active, positive definite."""
    m = 2 if mode is SensorMode.ACTIVE else 1
    R = check_covariance(np.atleast_2d(np.asarray(R, dtype=float)), 'reading covariance R')
    if R.shape != (m, m) or np.any(np.diag(R) <= 0):
        raise ValueError(f'{mode.value} reading covariance must be {m}x{m} positive definite, got {R!r}')
    return R


def collapsed(cov: np.ndarray, Q: np.ndarray | None = None) -> bool:
    """True when a cloud covariance is (numerically) singular or not finite.

    Singular: λmin ≤ COLLAPSE_RTOL·max(λmax, λmin(Q)) (``Q`` default: Table 1's eq. 4 with T = 1, q_s = 1).
    """
    if not np.all(np.isfinite(cov)):
        return True
    lam = np.linalg.eigvalsh(symmetrize(cov))
    q_min = float(np.linalg.eigvalsh(SonarParams().Q if Q is None else Q)[0])
    return bool(lam[0] <= COLLAPSE_RTOL * max(lam[-1], q_min))


def make_tracker(
    kind: str,
    params: SonarParams | None = None,
    rng: np.random.Generator | None = None,
    *,
    config: SSPFConfig | None = None,
    schedule: SchedulerConfig | None = None,
    **fields,
) -> SSPF:
    """'ss-pf' (eq. 7 scheduling with ``schedule``, ``SchedulerConfig``), 'papf' (passive only) or 'acpf'
    (active only), an ``SSPF`` of ``config``; ``fields`` override fields of either config by name."""
    if kind not in TRACKERS:
        raise ValueError(f'tracker must be one of {TRACKERS}, got {kind!r}')
    ours = {f.name for f in dataclasses.fields(SchedulerConfig)}
    sched_fields = {k: v for k, v in fields.items() if k in ours}
    sspf_fields = {k: v for k, v in fields.items() if k not in ours}
    if kind == 'ss-pf':
        sched: CovarianceScheduler | FixedScheduler = CovarianceScheduler(config=schedule, params=params,
                                                                          **sched_fields)
    else:
        sched = FixedScheduler(SensorMode.PASSIVE if kind == 'papf' else SensorMode.ACTIVE)
    return SSPF(params, sched, rng, config=config, **sspf_fields)
