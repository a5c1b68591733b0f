"""The paper's trackers: RB-UKF proposal (Algorithm 2) inside a particle filter with covariance-control
scheduling (Algorithm 3), and the PaPF/AcPF baselines of Section 5.

One ``SSPF`` object holds the whole filter state explicitly (particles, their UKF covariances,
the scheduler's next mode, a step counter) and is driven one measurement at a time by
``step(z, mode, observer_xy)``, so an experiment loop and a ROS node use it the same way.
All N particles are processed at once: (N, 4) means, (N, 4, 4) covariances, (N, 9, 4) sigma points.

Proposal covariance (a choice the paper leaves open). Algorithm 3 runs the RB-UKF "to x_kⁱ",
i.e. from the particle itself; the covariance attached to the particle is not stated.
- ``proposal='transition'`` (default): the particle is a point, P_kⁱ = 0, so the linear
  prediction gives N(F x_kⁱ, Q) and the UKF update approximates the locally optimal proposal
  p(x_{k+1} | x_kⁱ, z_{k+1}). The weights p(z|x)p(x|x_prev)/q(x) stay nearly uniform.
- ``proposal='propagated'``: the unscented-particle-filter reading (van der Merwe et al. 2000):
  each particle carries its UKF posterior covariance P_{k+1}ⁱ to the next step (resampled with
  it). The proposal is then much wider than p(x|x_prev) (position var. ≈ q_s T³/3), so the weights
  degenerate (ESS of a few particles); kept for comparison.

First step. The prior p(x₀) = N(m₀, P₀) is Gaussian and the model linear, so the first
proposal is one RB-UKF on N(m₀, P₀) itself and the transition density in the weight is the
exact predicted prior N(F m₀, F P₀ Fᵀ + Q). Starting from N points drawn from a 20 m prior
instead leaves only the few that land within a few metres of an active fix (ESS ≈ 1).

Selection. ``resample_threshold=1.0`` (default) resamples systematically at every step, as
Algorithm 3 does; a smaller value resamples only when ESS < threshold·N (weights carried).
``regularize=True`` (default; not in the paper) moves the selected particles with a Liu–West
shrinkage kernel, x ← a x + (1−a) x̄ + h L e, h = (4/(N(n+2)))^{1/(n+4)}, a = √(1−h²), L L' = Cov,
which keeps the cloud's mean and covariance but restores the diversity that resampling
removes. Without it the N = 200 cloud shrinks (AcPF ANEES ≈ 9 instead of ≈ 6) and the covariance
that drives the scheduler is too small.

Consistency. At N = 200 the filter is overconfident (AcPF ANEES ≈ 5.8–6.1 for 4 states, ≈ 2.8–3.0
for the position block alone): a Monte-Carlo effect, not a model mismatch. The weights are
checked against brute-force densities in the tests, the same AcPF gives 4.7 at N = 500 and 4.4
at N = 2000, and a single UKF on the same data gives 4.2. The excess grows over the run: the
velocity is learnt only through selection, so the particles' histories coalesce and the error of
the particle mean (not in the cloud's covariance) becomes a sizeable part of the total error.
Resampling only when ESS < N/2 does not change it.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from track_core.filters import (
    check_covariance,
    cholesky_jitter,
    effective_sample_size,
    gaussian_logpdf,
    kf_predict,
    normalize_log_weights,
    systematic_resample,
    unscented_update,
    unscented_weights,
    weighted_mean_cov,
)
from track_core.filters.unscented import UnscentedWeights
from track_core.sonar.models import SensorMode, SonarParams, measure, residual
from track_core.sonar.scheduler import CovarianceScheduler, FixedScheduler

log = logging.getLogger(__name__)

PROPOSALS = ('transition', 'propagated')
TRACKERS = ('ss-pf', 'papf', 'acpf')


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
) -> tuple[np.ndarray, np.ndarray]:
    """Algorithm 2 for a batch: linear prediction (eqs. 1–4), sigma points, unscented update.

    ``x`` (N, 4), ``P`` (N, 4, 4) or (4, 4); returns (x̃ (N, 4), P̃ (N, 4, 4)). P_u includes the
    measurement noise R (the paper's listing omits it; without R the update is not a UKF).
    ``h``/``R`` replace the sonar model (eq. 5/6 of ``mode``, with a wrapped bearing residual) by
    another measurement function z = h(x) + v, v ~ N(0, R), plain residual; the unit tests use a
    linear h to check that the update is exactly the Kalman update.
    """
    mode = SensorMode.parse(mode)
    w = weights or unscented_weights(4, params.ukf_alpha, params.ukf_beta, params.ukf_kappa)
    mu_p, P_p = kf_predict(x, P, params.F, params.Q)
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


@dataclass(frozen=True)
class SonarEstimate:
    """Output of one filter step (Algorithm 3, 'Output')."""

    k: int
    mean: np.ndarray  # (4,) E(x_k)
    cov: np.ndarray  # (4, 4) Cov(x_k), the 1/N sample covariance of the selected particles
    mode: SensorMode  # sensor used at this step
    next_mode: SensorMode  # sensor the scheduler chose for the next step
    ess: float  # effective sample size before the selection step


class SSPF:
    """Particle filter with RB-UKF proposal and a scheduler (eq. 7 or a fixed sensor).

    ``rng`` is the only randomness; the same seed and inputs reproduce a run bit for bit.
    Call ``initialize(mean, cov)`` (the prior p(x₀)) before the first ``step``.
    """

    def __init__(
        self,
        params: SonarParams | None = None,
        scheduler: CovarianceScheduler | FixedScheduler | None = None,
        rng: np.random.Generator | None = None,
        *,
        proposal: str = 'transition',
        resample_threshold: float = 1.0,
        regularize: bool = True,
    ) -> None:
        if not 0.0 < resample_threshold <= 1.0:
            raise ValueError(f'resample_threshold must be in (0, 1] (fraction of N), got {resample_threshold!r}')
        self.resample_threshold = resample_threshold
        self.regularize = regularize
        self.weights: np.ndarray | None = None
        if proposal not in PROPOSALS:
            raise ValueError(f'proposal must be one of {PROPOSALS}, got {proposal!r}')
        self.params = params or SonarParams()
        self.scheduler = scheduler if scheduler is not None else CovarianceScheduler()
        self.rng = rng if rng is not None else np.random.default_rng()
        self.proposal = proposal
        self._w = unscented_weights(4, self.params.ukf_alpha, self.params.ukf_beta, self.params.ukf_kappa)
        self._F, self._Q = self.params.F, self.params.Q
        self._L_Q = cholesky_jitter(self._Q)
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
        L = cholesky_jitter(cov)
        self.particles = mean + self.rng.standard_normal((self.n, 4)) @ L.T
        self.P = (np.broadcast_to(cov, (self.n, 4, 4)) if self.proposal == 'propagated'
                  else np.zeros((self.n, 4, 4))).copy()
        self.k = 0
        self.weights = None
        self._prior = (mean.copy(), cov.copy())
        self.scheduler.reset()
        self.estimate = None

    def step(self, z: np.ndarray, mode: SensorMode | str, observer_xy: np.ndarray) -> SonarEstimate:
        """One iteration of Algorithm 3 with the reading ``z`` taken by sensor ``mode`` from ``observer_xy``.

        ``z`` is [bearing] (passive) or [bearing, range] (active), bearing from north in rad.
        """
        if self.particles is None or self.P is None:
            raise RuntimeError('SSPF.step called before initialize()')
        mode = SensorMode.parse(mode)
        z = np.atleast_1d(np.asarray(z, dtype=float))
        m = 2 if mode is SensorMode.ACTIVE else 1
        if z.shape != (m,) or not np.all(np.isfinite(z)):
            raise ValueError(f'{mode.value} measurement must be {m} finite number(s), got {z!r}')
        obs = np.asarray(observer_xy, dtype=float)[:2]

        x_new, P_tilde, e, L, log_trans = self._propose(z, mode, obs)

        # w ∝ p(z|x) p(x|x_prev) / q(x); constants common to all particles dropped.
        R = self.params.R(mode)
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
                h = (4.0 / (self.n * (4 + 2))) ** (1.0 / (4 + 4))
                a = np.sqrt(1.0 - h**2)
                Lc = cholesky_jitter(cov)
                self.particles = (a * self.particles + (1 - a) * mean
                                  + h * self.rng.standard_normal((self.n, 4)) @ Lc.T)
                mean, cov = weighted_mean_cov(self.particles)
        else:
            self.particles, self.P, self.weights = x_new, P_keep, w
            mean, cov = weighted_mean_cov(x_new, w)
        self.k += 1
        next_mode = self.scheduler.decide(cov)
        self.estimate = SonarEstimate(self.k, mean, cov, mode, next_mode, ess)
        log.debug('k=%d mode=%s ess=%.1f next=%s', self.k, mode.value, ess, next_mode.value)
        return self.estimate

    def _propose(self, z: np.ndarray, mode: SensorMode, obs: np.ndarray):
        """Draw x ~ q = N(x̃ⁱ, P̃ⁱ) (Algorithm 3) and return it with the pieces the weights need."""
        x_prev = self.particles
        if self._prior is not None:
            # First step: the prior is Gaussian and the dynamics linear, so p(x₁) = N(F m₀, F P₀ Fᵀ + Q)
            # exactly; one RB-UKF on the whole prior gives the proposal for all N particles.
            m0, P0 = self._prior
            self._prior = None
            x_tilde, P_tilde = rb_ukf(m0[None], P0[None], z, mode, obs, self.params, self._w)
            L = cholesky_jitter(P_tilde)
            e = self.rng.standard_normal((self.n, 4))
            x_new = x_tilde + e @ L[0].T
            P_tilde = np.broadcast_to(P_tilde, (self.n, 4, 4))
            L = np.broadcast_to(L, (self.n, 4, 4))
            m_p = self._F @ m0
            log_trans = gaussian_logpdf(x_new - m_p, self._F @ P0 @ self._F.T + self._Q)
        else:
            # RB-UKF per particle (all at once), then x ~ N(x̃, P̃).
            x_tilde, P_tilde = rb_ukf(x_prev, self.P, z, mode, obs, self.params, self._w)
            L = cholesky_jitter(P_tilde)
            e = self.rng.standard_normal((self.n, 4))
            x_new = x_tilde + np.einsum('nij,nj->ni', L, e)
            d = x_new - x_prev @ self._F.T
            u = np.linalg.solve(self._L_Q, d.T).T
            log_trans = (-0.5 * np.sum(u * u, axis=-1) - np.sum(np.log(np.diagonal(self._L_Q)))
                         - 2.0 * np.log(2.0 * np.pi))

        return x_new, P_tilde, e, L, log_trans


def make_tracker(
    kind: str,
    params: SonarParams | None = None,
    rng: np.random.Generator | None = None,
    *,
    P_D: np.ndarray | None = None,
    delta: float = 5.0,
    metric: str = 'spectral',
    proposal: str = 'transition',
    resample_threshold: float = 1.0,
    regularize: bool = True,
) -> SSPF:
    """'ss-pf' (eq. 7 scheduling), 'papf' (passive only) or 'acpf' (active only)."""
    if kind == 'ss-pf':
        sched: CovarianceScheduler | FixedScheduler = CovarianceScheduler(P_D, delta, metric=metric)
    elif kind == 'papf':
        sched = FixedScheduler(SensorMode.PASSIVE)
    elif kind == 'acpf':
        sched = FixedScheduler(SensorMode.ACTIVE)
    else:
        raise ValueError(f'tracker must be one of {TRACKERS}, got {kind!r}')
    return SSPF(params, sched, rng, proposal=proposal, resample_threshold=resample_threshold,
                regularize=regularize)
