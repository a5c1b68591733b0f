"""Models of Liu, Ji, Zhang & Hao, "Blending sensor scheduling strategy with particle filter to
track a smart target" (2009): target dynamics (eqs. 1–4) and the two sonar sensors (eqs. 5–6).

State x = [x_t, ẋ_t, y_t, ẏ_t] (eq. 2) in the ENU ``map`` frame (x east, y north), metres and
m/s. Bearings follow the paper, atan((x_t − x_o)/(y_t − y_o)), i.e. clockwise from north,
computed with atan2 so all four quadrants are right; residuals are wrapped to (−π, π].
(A node converts to/from REP-103 yaw at its boundary: yaw = π/2 − bearing.)

Parameters are validated when a ``SonarParams`` is built; a bad value raises ``ValueError``
with one line naming the parameter, the value and the allowed range.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum

import numpy as np

from track_core.filters import cv_process_noise, cv_transition, wrap_angle


class SensorMode(StrEnum):
    """Which sonar is used at a step: passive (bearing, eq. 5) or active (bearing + range, eq. 6)."""

    PASSIVE = 'passive'
    ACTIVE = 'active'

    @classmethod
    def parse(cls, mode: SensorMode | str | bool) -> SensorMode:
        """Accept a ``SensorMode``, 'passive'/'active', or a bool (True = active)."""
        if isinstance(mode, cls):
            return mode
        if isinstance(mode, bool | np.bool_):
            return cls.ACTIVE if mode else cls.PASSIVE
        try:
            return cls(str(mode).lower())
        except ValueError:
            raise ValueError(f"sensor mode must be 'passive' or 'active', got {mode!r}") from None


def _require(cond: bool, name: str, value: object, allowed: str) -> None:
    if not cond:
        raise ValueError(f'{name} must be {allowed}, got {value!r}')


@dataclass(frozen=True)
class SonarParams:
    """Table 1 of the paper (defaults) plus the UKF sigma-point parameters.

    - ``T`` sampling period (s), ``q_s`` acceleration-noise PSD of eq. 4 (m²/s³);
    - ``sigma_b`` bearing noise std (rad; Table 1: 1°), ``sigma_d`` range noise std (m; 5 m);
    - ``n_particles`` N (200);
    - ``ukf_alpha``, ``ukf_beta``, ``ukf_kappa``: scaled-UT parameters α, β, κ of Algorithm 2
      (not given in the paper; α = 1, β = 2, κ = 0 → λ = 0, sigma points at ±2·√P columns).
    """

    T: float = 1.0
    q_s: float = 1.0
    sigma_b: float = math.radians(1.0)
    sigma_d: float = 5.0
    n_particles: int = 200
    ukf_alpha: float = 1.0
    ukf_beta: float = 2.0
    ukf_kappa: float = 0.0

    def __post_init__(self) -> None:
        _require(math.isfinite(self.T) and self.T > 0, 'T', self.T, 'a finite number > 0 (s)')
        _require(math.isfinite(self.q_s) and self.q_s > 0, 'q_s', self.q_s, 'a finite number > 0 (m^2/s^3)')
        _require(math.isfinite(self.sigma_b) and self.sigma_b > 0, 'sigma_b', self.sigma_b,
                 'a finite number > 0 (rad)')
        _require(math.isfinite(self.sigma_d) and self.sigma_d > 0, 'sigma_d', self.sigma_d,
                 'a finite number > 0 (m)')
        _require(isinstance(self.n_particles, int | np.integer) and self.n_particles >= 1,
                 'n_particles', self.n_particles, 'an integer >= 1')
        _require(self.ukf_alpha > 0, 'ukf_alpha', self.ukf_alpha, '> 0')
        _require(4 + self.ukf_alpha**2 * (4 + self.ukf_kappa) - 4 > 0, 'ukf_kappa', self.ukf_kappa,
                 'such that n + lambda > 0 (kappa > -4)')

    @property
    def F(self) -> np.ndarray:  # noqa: N802 - the paper's symbol
        """Eq. 3."""
        return cv_transition(self.T)

    @property
    def Q(self) -> np.ndarray:  # noqa: N802 - the paper's symbol
        """Eq. 4."""
        return cv_process_noise(self.T, self.q_s)

    def R(self, mode: SensorMode | str) -> np.ndarray:  # noqa: N802 - the paper's symbol
        """Measurement-noise covariance: R_b (passive, eq. 5) or diag[R_b, R_d] (active, eq. 6)."""
        if SensorMode.parse(mode) is SensorMode.ACTIVE:
            return np.diag([self.sigma_b**2, self.sigma_d**2])
        return np.array([[self.sigma_b**2]])


def bearing(target_xy: np.ndarray, observer_xy: np.ndarray) -> np.ndarray:
    """Bearing from north, atan2(x_t − x_o, y_t − y_o), for (..., 2) positions."""
    d = np.asarray(target_xy, dtype=float) - np.asarray(observer_xy, dtype=float)
    return np.arctan2(d[..., 0], d[..., 1])


def measure(x: np.ndarray, observer_xy: np.ndarray, mode: SensorMode | str) -> np.ndarray:
    """Noise-free h(x) for states (..., 4): (..., 1) passive [bearing] or (..., 2) active [bearing, range]."""
    x = np.asarray(x, dtype=float)
    dx = x[..., 0] - observer_xy[0]
    dy = x[..., 2] - observer_xy[1]
    b = np.arctan2(dx, dy)
    if SensorMode.parse(mode) is SensorMode.ACTIVE:
        return np.stack([b, np.hypot(dx, dy)], axis=-1)
    return b[..., None]


def residual(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a − b for measurements whose first component is a bearing (wrapped to (−π, π])."""
    d = np.asarray(a, dtype=float) - np.asarray(b, dtype=float)
    return np.concatenate([wrap_angle(d[..., :1]), d[..., 1:]], axis=-1)


def simulate_measurement(
    rng: np.random.Generator, x: np.ndarray, observer_xy: np.ndarray, mode: SensorMode | str, params: SonarParams
) -> np.ndarray:
    """A noisy reading of the true state ``x`` (4,): eq. 5 or eq. 6, bearing wrapped to (−π, π]."""
    z = measure(x, observer_xy, mode)
    noise = rng.normal(size=z.shape) * np.sqrt(np.diag(params.R(mode)))
    return residual(z + noise, np.zeros_like(z))
