"""Sensor models (§3): acoustic amplitude (eqs. 5-6) and DOA bearing (eq. 11, Fig. 6).

Conventions and interpretations:
- Frame: ENU, x east, y north. The paper's bearing θ is measured from the grid's *vertical*
  axis (Fig. 4: "with respect to the vertical grid axis"; field DOA arrays were aligned to
  magnetic north), clockwise, i.e. θ = atan2(dx, dy), wrapped to (−π, π] with
  ``filters.wrap_angle``. θ = 0 is north, +π/2 east.
- Eq. 11 ignores the 2π periodicity; we evaluate it on the wrapped innovation wrap(z − θ), which
  equals eq. 11 when σ is small and is correct across ±π.
- Fig. 6 σ(r) (tracker's DOA model): σ₀ = 10° on [r_near, r_far] = [20, 100] m; the slopes are
  not given. Far field: +0.2°/m beyond r_far (σ(200 m) = 30°), capped at σ_max = 90°. Near field:
  σ grows linearly as r falls and reaches the cap at the sensor, σ(0) = σ_max: slope (σ_max −
  σ₀)/r_near = 4°/m by default (``near_slope=None`` derives it; a number overrides), since the
  likelihood "fans out" in the near range (§3.2, Fig. 7). Measured reasons: docs/results/idsq.md.
- Eq. 6 is the density of z given the range r (a ~ U[a_lo, a_hi], w ~ N(0, σ²)). Φ is the
  standard normal CDF (``scipy.stats.norm.cdf``). r = 0 gives 0 (the limit of eq. 6).
- Simulation (§5.1): acoustic z = A/‖x − ζ‖ + N(0, 0.05²); DOA z = θ + N(0, (3°)²), wrapped.
  A DOA array is also a set of microphones: ``sensor amplitude`` readings are simulated for
  every sensor, but only used to pick the start leader (see ``network.start_leader``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.stats import norm

from track_core.filters import wrap_angle
from track_core.idsq.grid import SPARSITY_THRESHOLD

DEG = np.pi / 180.0


@dataclass(frozen=True)
class TrackerParams:
    """Tracker settings of §5.1 (defaults) and the Fig. 6 slopes (ours, see module docstring)."""

    v_max: float = 15.0            # m/s
    dt: float = 0.5                # s
    a_lo: float = 0.0
    a_hi: float = 80.0
    sigma_a: float = 0.1           # σ_k of eq. 6
    r_near: float = 20.0           # m
    r_far: float = 100.0           # m
    sigma_doa: float = 10.0 * DEG  # Fig. 6 σ in [r_near, r_far]
    near_slope: float | None = None  # rad per m as r falls below r_near; None: σ(0) = sigma_doa_max (see above)
    far_slope: float = 0.2 * DEG   # rad per m, beyond r_far
    sigma_doa_max: float = 90.0 * DEG
    sparsity: float = SPARSITY_THRESHOLD  # relative threshold of §2.3 (see grid.py)
    prediction: str = 'diffusion'  # 'diffusion' (§2.1, the paper's) or 'drift' (ours, prediction.py)
    drift_gain: float = 0.3        # β of the v̂ average (prediction.py)
    drift_gate: float = 4.0        # v̂ observed only when both spreads < drift_gate·(v_max·Δt)² [m²]
    drift_speed: float | None = None  # |v − v̂| bound of the drift disk [m/s]; None = v_max
    bank_step: float = 5.0         # velocity-lattice spacing of prediction='bank' [m/s]
    bank_switch: float = 0.1       # probability of switching to a neighbouring velocity per bank_switch_dt
    bank_switch_dt: float = 0.5    # [s] the interval bank_switch is given for (a rate: see switch_per_step)

    def __post_init__(self) -> None:
        pos = {'v_max': self.v_max, 'dt': self.dt, 'sigma_a': self.sigma_a, 'sigma_doa': self.sigma_doa,
               'sigma_doa_max': self.sigma_doa_max}
        for k, v in pos.items():
            if not (np.isfinite(v) and v > 0):
                raise ValueError(f'{k}={v} must be finite and > 0')
        if not (np.isfinite(self.a_lo) and np.isfinite(self.a_hi) and 0 <= self.a_lo < self.a_hi):
            raise ValueError(f'a_lo={self.a_lo}, a_hi={self.a_hi} must satisfy 0 <= a_lo < a_hi < inf')
        if not (0 <= self.r_near < self.r_far < np.inf):
            raise ValueError(f'r_near={self.r_near}, r_far={self.r_far} must satisfy 0 <= r_near < r_far < inf')
        if not 0.0 <= self.sparsity < 1.0:
            raise ValueError(f'sparsity={self.sparsity} must be in [0, 1)')
        self._check_prediction()
        if self.near_slope is None:  # Fig. 6 near field reaching "no evidence" (σ_max) at the sensor
            slope = (self.sigma_doa_max - self.sigma_doa) / self.r_near if self.r_near > 0 else 0.0
            object.__setattr__(self, 'near_slope', float(max(slope, 0.0)))
        for k in ('near_slope', 'far_slope'):
            v = getattr(self, k)
            if not (np.isfinite(v) and v >= 0):
                raise ValueError(f'{k}={v} must be finite and >= 0 rad/m')

    def _check_prediction(self) -> None:
        """Settings of the prediction step (``prediction.py``); resolves ``drift_speed=None`` to v_max."""
        if self.prediction not in ('diffusion', 'drift', 'bank'):
            raise ValueError(f"prediction={self.prediction!r} must be 'diffusion', 'drift' or 'bank'")
        if not (np.isfinite(self.bank_step) and 0 < self.bank_step <= self.v_max):
            raise ValueError(f'bank_step={self.bank_step} must be in (0, v_max={self.v_max}] m/s')
        if not 0.0 <= self.bank_switch <= 1.0:
            raise ValueError(f'bank_switch={self.bank_switch} must be in [0, 1]')
        if not (np.isfinite(self.bank_switch_dt) and self.bank_switch_dt > 0):
            raise ValueError(f'bank_switch_dt={self.bank_switch_dt} must be finite and > 0 s')
        if not (np.isfinite(self.drift_gain) and 0.0 < self.drift_gain <= 1.0):
            raise ValueError(f'drift_gain={self.drift_gain} must be in (0, 1]')
        if not (np.isfinite(self.drift_gate) and self.drift_gate > 0):
            raise ValueError(f'drift_gate={self.drift_gate} must be finite and > 0')
        if self.drift_speed is None:
            object.__setattr__(self, 'drift_speed', self.v_max)
        elif not (np.isfinite(self.drift_speed) and self.drift_speed >= 0):
            raise ValueError(f'drift_speed={self.drift_speed} must be finite and >= 0 m/s')

    @property
    def switch_per_step(self) -> float:
        """Probability that the bank's velocity switches during one step Δt: ``bank_switch`` is given per
        ``bank_switch_dt``, i.e. a manoeuvre rate, so a step of Δt switches with 1 − (1 − bank_switch)^(Δt /
        bank_switch_dt) (exactly ``bank_switch`` when Δt = bank_switch_dt; ``prediction.py``)."""
        if self.dt == self.bank_switch_dt or self.bank_switch in (0.0, 1.0):
            return float(self.bank_switch)
        return float(-np.expm1(np.log1p(-self.bank_switch) * (self.dt / self.bank_switch_dt)))

    @property
    def radius(self) -> float:
        """Diffusion disk radius v_max·Δt (§2.1)."""
        return self.v_max * self.dt


@dataclass(frozen=True)
class SimNoise:
    """§5.1 truth-side constants: source amplitude A and the actual measurement noises."""

    amplitude: float = 40.0
    sigma_a: float = 0.05
    sigma_doa: float = 3.0 * DEG


def ranges(xy: np.ndarray, sensor: np.ndarray) -> np.ndarray:
    """‖x − ζ‖ for points ``xy`` (..., 2) and one sensor position ζ (2,)."""
    d = np.asarray(xy, dtype=float) - np.asarray(sensor, dtype=float)
    return np.hypot(d[..., 0], d[..., 1])


def bearings(xy: np.ndarray, sensor: np.ndarray) -> np.ndarray:
    """θ(x, ζ) from the vertical (north) axis, clockwise: atan2(dx, dy) in (−π, π]."""
    d = np.asarray(xy, dtype=float) - np.asarray(sensor, dtype=float)
    return wrap_angle(np.arctan2(d[..., 0], d[..., 1]))


def acoustic_likelihood(z: np.ndarray | float, r: np.ndarray, p: TrackerParams) -> np.ndarray:
    """Eq. 6: p(z|r) = r/Δa · [Φ((a_hi − r z)/(r σ)) − Φ((a_lo − r z)/(r σ))]; broadcasts z against r."""
    z = np.asarray(z, dtype=float)
    r = np.asarray(r, dtype=float)
    rs = np.maximum(r, 1e-9) * p.sigma_a
    rz = r * z
    out = r / (p.a_hi - p.a_lo) * (norm.cdf((p.a_hi - rz) / rs) - norm.cdf((p.a_lo - rz) / rs))
    return np.clip(out, 0.0, None)


def doa_sigma(r: np.ndarray, p: TrackerParams) -> np.ndarray:
    """Fig. 6: σ(r) = σ₀ on [r_near, r_far], linear growth outside (slopes in TrackerParams), capped."""
    r = np.asarray(r, dtype=float)
    s = (p.sigma_doa + p.near_slope * np.clip(p.r_near - r, 0.0, None)
         + p.far_slope * np.clip(r - p.r_far, 0.0, None))
    return np.minimum(s, p.sigma_doa_max)


def doa_likelihood(z: np.ndarray | float, theta: np.ndarray, r: np.ndarray, p: TrackerParams) -> np.ndarray:
    """Eq. 11 on the wrapped innovation: N(wrap(z − θ); 0, σ(r)²), σ(r) from Fig. 6."""
    s = doa_sigma(r, p)
    e = wrap_angle(np.asarray(z, dtype=float) - np.asarray(theta, dtype=float))
    return np.exp(-0.5 * (e / s) ** 2) / (np.sqrt(2.0 * np.pi) * s)


def likelihood(z: float, xy: np.ndarray, sensor: np.ndarray, is_doa: bool, p: TrackerParams) -> np.ndarray:
    """p(z|x) at the points ``xy`` (n, 2) for one sensor (eq. 6 or eq. 11)."""
    r = ranges(xy, sensor)
    if is_doa:
        return doa_likelihood(z, bearings(xy, sensor), r, p)
    return acoustic_likelihood(z, r, p)


def simulate_measurement(truth_xy: np.ndarray, sensor: np.ndarray, is_doa: bool, noise: SimNoise,
                         std_normal: float) -> float:
    """One §5.1 measurement given a standard-normal draw (common random numbers across trackers)."""
    if is_doa:
        return float(wrap_angle(bearings(truth_xy, sensor) + noise.sigma_doa * std_normal))
    return float(noise.amplitude / max(float(ranges(truth_xy, sensor)), 1e-6) + noise.sigma_a * std_normal)


def amplitude_reading(truth_xy: np.ndarray, sensor: np.ndarray, noise: SimNoise, std_normal: float) -> float:
    """Acoustic amplitude reading A/r + noise (what any microphone, DOA arrays included, hears)."""
    return simulate_measurement(truth_xy, sensor, False, noise, std_normal)


def loudest_source(sources: np.ndarray, sensors: np.ndarray) -> np.ndarray:
    """Source each sensor hears loudest: the nearest (every source has amplitude A and A/r falls with r).

    ``sources`` (2,) or (M, 2); ``sensors`` (2,) → (2,), or (K, 2) → (K, 2). Ties go to the first source.
    """
    src = np.asarray(sources, dtype=float).reshape(-1, 2)
    sen = np.asarray(sensors, dtype=float)
    nearest = np.argmin(ranges(src[None, :, :], sen.reshape(-1, 1, 2)), axis=1)  # (K, M) ranges
    return src[nearest[0]] if sen.ndim == 1 else src[nearest]


def amplitude_readings(sources: np.ndarray, sensors: np.ndarray, noise: SimNoise,
                       std_normals: np.ndarray) -> np.ndarray:
    """``amplitude_reading`` of every sensor (K, 2) at once, each hearing its loudest source; bit-identical
    to the scalar version (same elementwise operations)."""
    sen = np.asarray(sensors, dtype=float).reshape(-1, 2)
    r = ranges(loudest_source(sources, sen), sen)
    return noise.amplitude / np.maximum(r, 1e-6) + noise.sigma_a * np.asarray(std_normals, dtype=float)
