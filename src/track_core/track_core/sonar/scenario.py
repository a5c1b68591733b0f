"""Section 5 scenario: observer trajectory, target truth, prior, and one Monte-Carlo run.

Observer (Figure 1 is not in the text; designed in its spirit). The observer AUV moves at a
constant 10 m/s and makes two manoeuvres within the 40 s run, which makes the range
observable from bearings alone. ``DEFAULT_LEGS`` from (0 m, 0 m), heading 90° (east; headings
clockwise from north like the paper's bearings):

| t (s)   | leg                                   |
|---------|---------------------------------------|
| 0–10    | straight, heading 90° (east)          |
| 10–16   | manoeuvre 1: turn right 15°/s → 180°  |
| 16–24   | straight, heading 180° (south)        |
| 24–30   | manoeuvre 2: turn left 15°/s → 90°    |
| 30–…    | straight, heading 90° (east)          |

Target: x₀ = [300 m, 12.25 m/s, 300 m, −12.25 m/s] (Section 5), then eq. 1 with q_s = 1.

Prior (not given in the paper): p(x₀) = N(m₀, P₀) with P₀ = diag(σ_p², σ_v², σ_p², σ_v²),
σ_p = 20 m, σ_v = 2 m/s, and m₀ drawn per run as x₀ + N(0, P₀), so the truth is a draw from
the prior each filter is given (a consistent start for NEES).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from track_core.metrics import SINGULAR_ATOL, SINGULAR_RTOL, nees_or_nan  # noqa: F401 (re-exported)
from track_core.sonar.models import SensorMode, SonarParams, measure, residual

# (duration s, turn rate deg/s); the last leg extends past its duration.
DEFAULT_LEGS: tuple[tuple[float, float], ...] = ((10.0, 0.0), (6.0, 15.0), (8.0, 0.0), (6.0, -15.0), (10.0, 0.0))
TARGET_X0 = (300.0, 12.25, 300.0, -12.25)


@dataclass(frozen=True)
class ObserverTrajectory:
    """Constant-speed path of straight legs and constant-rate turns; ``state(t)`` = [x, ẋ, y, ẏ]."""

    start: tuple[float, float] = (0.0, 0.0)
    speed: float = 10.0
    heading0_deg: float = 90.0
    legs: tuple[tuple[float, float], ...] = DEFAULT_LEGS

    def __post_init__(self) -> None:
        if not (math.isfinite(self.speed) and self.speed >= 0):
            raise ValueError(f'observer speed must be a finite number >= 0 (m/s), got {self.speed!r}')
        if not self.legs or any(d <= 0 for d, _ in self.legs):
            raise ValueError(f'observer legs must be non-empty with durations > 0, got {self.legs!r}')

    def state(self, t: float) -> np.ndarray:
        """[x, ẋ, y, ẏ] at time t ≥ 0 (s), integrated exactly over the arcs."""
        x, y = self.start
        h = math.radians(self.heading0_deg)
        v = self.speed
        remaining = max(float(t), 0.0)
        for i, (dur, rate_deg) in enumerate(self.legs):
            dt = remaining if i == len(self.legs) - 1 else min(remaining, dur)
            w = math.radians(rate_deg)
            if abs(w) < 1e-12:
                x += v * dt * math.sin(h)
                y += v * dt * math.cos(h)
            else:  # heading h(t) = h + w t; (ẋ, ẏ) = v (sin h, cos h)
                x += v / w * (math.cos(h) - math.cos(h + w * dt))
                y += v / w * (math.sin(h + w * dt) - math.sin(h))
            h += w * dt
            remaining -= dt
            if remaining <= 0:
                break
        return np.array([x, v * math.sin(h), y, v * math.cos(h)])

    def position(self, t: float) -> np.ndarray:
        s = self.state(t)
        return np.array([s[0], s[2]])


@dataclass(frozen=True)
class Scenario:
    """Section 5 / Table 1 set-up. ``n_steps`` readings at t = T, 2T, …; prior at t = 0."""

    params: SonarParams = field(default_factory=SonarParams)
    observer: ObserverTrajectory = field(default_factory=ObserverTrajectory)
    target_x0: tuple[float, float, float, float] = TARGET_X0
    n_steps: int = 40
    prior_pos_std: float = 20.0
    prior_vel_std: float = 2.0

    def __post_init__(self) -> None:
        if self.n_steps < 1:
            raise ValueError(f'n_steps must be an integer >= 1, got {self.n_steps!r}')
        if not (self.prior_pos_std > 0 and self.prior_vel_std > 0):
            raise ValueError('prior_pos_std and prior_vel_std must be > 0, '
                             f'got {self.prior_pos_std!r}, {self.prior_vel_std!r}')

    @property
    def times(self) -> np.ndarray:
        return self.params.T * np.arange(1, self.n_steps + 1)

    @property
    def prior_cov(self) -> np.ndarray:
        return np.diag([self.prior_pos_std**2, self.prior_vel_std**2] * 2)

    def observer_positions(self) -> np.ndarray:
        """(n_steps, 2) observer positions at the measurement times."""
        return np.array([self.observer.position(t) for t in self.times])

    def simulate_truth(self, rng: np.random.Generator) -> np.ndarray:
        """(n_steps + 1, 4) true states x₀ … x_K from eq. 1 (x₀ fixed)."""
        F, L = self.params.F, np.linalg.cholesky(self.params.Q)
        x = np.empty((self.n_steps + 1, 4))
        x[0] = self.target_x0
        w = rng.standard_normal((self.n_steps, 4)) @ L.T
        for k in range(self.n_steps):
            x[k + 1] = F @ x[k] + w[k]
        return x

    def draw_prior_mean(self, rng: np.random.Generator, x0: np.ndarray) -> np.ndarray:
        return np.asarray(x0, dtype=float) + np.linalg.cholesky(self.prior_cov) @ rng.standard_normal(4)


@dataclass
class RunResult:
    """One Monte-Carlo run of one tracker: per-step estimates, modes and errors."""

    truth: np.ndarray  # (K+1, 4)
    mean: np.ndarray  # (K, 4)
    cov: np.ndarray  # (K, 4, 4)
    active: np.ndarray  # (K,) bool, sensor used at step k
    observer: np.ndarray  # (K, 2)

    @property
    def pos_err_sq(self) -> np.ndarray:
        d = self.mean - self.truth[1:]
        return d[:, 0] ** 2 + d[:, 2] ** 2

    @property
    def nees(self) -> np.ndarray:
        """(K,) NEES of the full state; NaN where the covariance is singular (see ``nees_reasons``)."""
        return nees_or_nan(self.truth[1:] - self.mean, self.cov)[0]

    @property
    def nees_pos(self) -> np.ndarray:
        """NEES of the position block [x, y] alone (2 degrees of freedom); NaN where singular."""
        pos = [0, 2]
        return nees_or_nan((self.truth[1:] - self.mean)[:, pos], self.cov[:, pos][:, :, pos])[0]

    @property
    def nees_reasons(self) -> list[str | None]:
        """Per step, why the full-state NEES is NaN (None where it is defined)."""
        return nees_or_nan(self.truth[1:] - self.mean, self.cov)[1]


def measurement_jacobian(x: np.ndarray, observer_xy: np.ndarray, mode: SensorMode | str) -> np.ndarray:
    """∂h/∂x of eq. 5 (passive, (..., 1, 4)) or eq. 6 (active, (..., 2, 4)) at states ``x`` (..., 4)."""
    x = np.asarray(x, dtype=float)
    dx, dy = x[..., 0] - observer_xy[0], x[..., 2] - observer_xy[1]
    r2 = dx * dx + dy * dy
    r = np.sqrt(r2)
    zero = np.zeros_like(dx)
    rows = [np.stack([dy / r2, zero, -dx / r2, zero], axis=-1)]  # d atan2(dx, dy)
    if SensorMode.parse(mode) is SensorMode.ACTIVE:
        rows.append(np.stack([dx / r, zero, dy / r, zero], axis=-1))
    return np.stack(rows, axis=-2)


def pcrlb(scenario: Scenario, truths: np.ndarray, active: np.ndarray | None = None) -> np.ndarray:
    """Posterior Cramér–Rao bound (Tichavský et al. 1998) of the state at steps 1…K: (K, 4, 4).

    Linear-Gaussian dynamics (eq. 1) give J_{k+1} = (Q + F J_k⁻¹ Fᵀ)⁻¹ + E[Hᵀ R⁻¹ H], with the
    expectation over the Monte-Carlo ``truths`` (M, K+1, 4) and J₀ = P₀⁻¹. ``active`` (K,) is the
    schedule (default: active at every step, the best any schedule can do). Any estimator's error
    covariance is ≥ the bound, so a consistent filter's covariance is too.
    """
    p, K = scenario.params, scenario.n_steps
    act = np.ones(K, bool) if active is None else np.asarray(active, bool)
    obs = scenario.observer_positions()
    F, Q = p.F, p.Q
    J = np.linalg.inv(scenario.prior_cov)
    out = np.empty((K, 4, 4))
    for k in range(K):
        mode = SensorMode.ACTIVE if act[k] else SensorMode.PASSIVE
        H = measurement_jacobian(truths[:, k + 1], obs[k], mode)
        info = np.mean(np.swapaxes(H, -1, -2) @ np.linalg.inv(p.R(mode)) @ H, axis=0)
        J = np.linalg.inv(Q + F @ np.linalg.inv(J) @ F.T) + info
        out[k] = np.linalg.inv(J)
    return out


def run_once(scenario: Scenario, tracker, truth: np.ndarray, prior_mean: np.ndarray,
             noise: np.ndarray) -> RunResult:
    """Run ``tracker`` (an initialised-on-entry ``SSPF``) over ``truth`` with common random numbers.

    ``noise`` (K, 2) standard normals: the bearing noise is σ_b·noise[k, 0] in both modes and the
    range noise σ_d·noise[k, 1], so different trackers see the same noise realisation.
    """
    p = scenario.params
    tracker.initialize(prior_mean, scenario.prior_cov)
    obs = scenario.observer_positions()
    K = scenario.n_steps
    means, covs, active = np.empty((K, 4)), np.empty((K, 4, 4)), np.zeros(K, bool)
    scale = np.array([p.sigma_b, p.sigma_d])
    for k in range(K):
        mode = tracker.next_mode
        z_clean = measure(truth[k + 1], obs[k], mode)
        z = residual(z_clean + scale[: z_clean.size] * noise[k, : z_clean.size], np.zeros_like(z_clean))
        est = tracker.step(z, mode, obs[k])
        means[k], covs[k], active[k] = est.mean, est.cov, mode is SensorMode.ACTIVE
    return RunResult(truth, means, covs, active, obs)
