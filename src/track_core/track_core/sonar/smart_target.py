"""A target that hears active pings and evades (beyond the paper, whose target never reacts).

Ping detection. Each active ping emitted by the observer is heard with probability

    P_det(r) = p_max / (1 + exp((r − r_50) / w))

(a logistic fall-off in range r between observer and target: ≈ p_max close in, p_max/2 at
r = r_50, → 0 beyond r_50 + 4w). Defaults p_max = 0.9, r_50 = 600 m, w = 100 m, so the
≈ 400–600 m ranges of the Section 5 scenario give P_det ≈ 0.5–0.8 per ping.

Evasion. After a detected ping the target enters EVADE: it steers towards the heading pointing
directly away from the observer (the bearing observer → target) and speeds up to
``evade_speed``, with the turn rate bounded by ``max_turn_rate`` (rad/s) and the speed change by
``max_accel`` (m/s²) per step. After ``quiet_period`` s without a detected ping it returns to
CRUISE: it holds its current heading and slows back to its cruise speed (the speed at start),
again with bounded acceleration. Defaults: evade_speed 22 m/s (cruise 17.3 m/s), max_turn_rate
3°/s, max_accel 1 m/s², quiet_period 10 s. On top of the commanded motion it receives the CV process
noise of eq. 4 (q_s), so in ``naive`` mode it is exactly the paper's eq. 1 target.
Headings are clockwise from north, like the bearings.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from track_core.filters import cv_transition
from track_core.sonar.models import SonarParams


@dataclass(frozen=True)
class SmartTargetParams:
    p_max: float = 0.9
    r_50: float = 600.0
    width: float = 100.0
    evade_speed: float = 22.0
    max_turn_rate: float = math.radians(3.0)
    max_accel: float = 1.0
    quiet_period: float = 10.0
    naive: bool = False

    def __post_init__(self) -> None:
        checks = [
            ('p_max', 0.0 <= self.p_max <= 1.0, 'in [0, 1]'),
            ('r_50', math.isfinite(self.r_50) and self.r_50 > 0, '> 0 (m)'),
            ('width', math.isfinite(self.width) and self.width > 0, '> 0 (m)'),
            ('evade_speed', math.isfinite(self.evade_speed) and self.evade_speed >= 0, '>= 0 (m/s)'),
            ('max_turn_rate', math.isfinite(self.max_turn_rate) and self.max_turn_rate >= 0, '>= 0 (rad/s)'),
            ('max_accel', math.isfinite(self.max_accel) and self.max_accel >= 0, '>= 0 (m/s^2)'),
            ('quiet_period', math.isfinite(self.quiet_period) and self.quiet_period >= 0, '>= 0 (s)'),
        ]
        for name, ok, allowed in checks:
            if not ok:
                raise ValueError(f'{name} must be {allowed}, got {getattr(self, name)!r}')

    def detection_probability(self, r: float | np.ndarray) -> np.ndarray:
        """P_det(r), the probability that one ping at range r (m) is heard."""
        return self.p_max / (1.0 + np.exp((np.asarray(r, dtype=float) - self.r_50) / self.width))


def evasive_transition(x: np.ndarray, evading: np.ndarray, observer_xy: np.ndarray, cruise_speed: np.ndarray,
                       params: SmartTargetParams, T: float) -> np.ndarray:
    """The commanded (noise-free) motion of N targets over one period, vectorised: (N, 4) → (N, 4).

    ``evading`` (N,) bool: steer away from the observer towards ``evade_speed``; else hold the
    heading and return to ``cruise_speed`` (N,). Turn and speed change are clipped to the rates;
    the position integrates the mean of the old and new velocity. ``naive`` params give F x (eq. 1).
    The truth (``SmartTarget``) and the SS-PF's target model (``SSPF(target_model=...)``) both use it.
    """
    x = np.asarray(x, dtype=float)
    p = params
    if p.naive:
        return x @ cv_transition(T).T
    vx, vy = x[:, 1], x[:, 3]
    speed, heading = np.hypot(vx, vy), np.arctan2(vx, vy)
    away = np.arctan2(x[:, 0] - observer_xy[0], x[:, 2] - observer_xy[1])
    want_h = np.where(evading, away, heading)
    want_v = np.where(evading, p.evade_speed, cruise_speed)
    dh = (want_h - heading + np.pi) % (2 * np.pi) - np.pi
    heading = heading + np.clip(dh, -p.max_turn_rate * T, p.max_turn_rate * T)
    speed = speed + np.clip(want_v - speed, -p.max_accel * T, p.max_accel * T)
    vxn, vyn = speed * np.sin(heading), speed * np.cos(heading)
    return np.stack([x[:, 0] + 0.5 * T * (vx + vxn), vxn, x[:, 2] + 0.5 * T * (vy + vyn), vyn], axis=1)


def batched_transition(evading: np.ndarray, observer_xy: np.ndarray, cruise_speed: np.ndarray,
                       params: SmartTargetParams, T: float):
    """``evasive_transition`` as f(χ) for the sigma points χ (N, S, 4) of N Gaussians, each Gaussian with its
    own ``evading`` flag and ``cruise_speed`` (N,): the f of ``filters.unscented_predict``."""
    def f(chi: np.ndarray) -> np.ndarray:
        n_s = chi.shape[-2]
        return evasive_transition(chi.reshape(-1, 4), np.repeat(evading, n_s), observer_xy,
                                  np.repeat(cruise_speed, n_s), params, T).reshape(chi.shape)
    return f


@dataclass
class SmartTarget:
    """Truth simulator with explicit state; ``step(rng, pinged, observer_xy)`` advances one period T."""

    x: np.ndarray
    sonar: SonarParams = field(default_factory=SonarParams)
    params: SmartTargetParams = field(default_factory=SmartTargetParams)
    t: float = 0.0
    evading: bool = False
    last_detection_t: float | None = None
    first_detection_t: float | None = None
    detections: int = 0
    pings: int = 0

    def __post_init__(self) -> None:
        self.x = np.asarray(self.x, dtype=float).copy()
        if self.x.shape != (4,) or not np.all(np.isfinite(self.x)):
            raise ValueError(f'target state must be 4 finite numbers [x, vx, y, vy], got {self.x!r}')
        self.cruise_speed = float(math.hypot(self.x[1], self.x[3]))
        self._F = self.sonar.F
        self._L_Q = np.linalg.cholesky(self.sonar.Q)

    @property
    def mode(self) -> str:
        return 'naive' if self.params.naive else ('evade' if self.evading else 'cruise')

    def hear(self, rng: np.random.Generator, observer_xy: np.ndarray) -> bool:
        """One ping at the current state: draw whether the target detects it (and count it)."""
        self.pings += 1
        r = math.hypot(self.x[0] - observer_xy[0], self.x[2] - observer_xy[1])
        heard = bool(rng.random() < self.params.detection_probability(r))
        if heard:
            self.detections += 1
            self.last_detection_t = self.t
            if self.first_detection_t is None:
                self.first_detection_t = self.t
        return heard

    def step(self, rng: np.random.Generator, pinged: bool, observer_xy: np.ndarray) -> np.ndarray:
        """Hear (or not) a ping at the current time, react, and move to t + T. Returns the new state."""
        obs = np.asarray(observer_xy, dtype=float)[:2]
        if pinged:
            self.hear(rng, obs)
        p = self.params
        if not p.naive:
            if self.last_detection_t is not None and self.t - self.last_detection_t < p.quiet_period:
                self.evading = True
            elif self.evading:
                self.evading = False
        x_det = evasive_transition(self.x[None], np.array([self.evading]), obs, np.array([self.cruise_speed]),
                                   p, self.sonar.T)[0]
        self.x = x_det + self._L_Q @ rng.standard_normal(4)
        self.t += self.sonar.T
        return self.x.copy()
