"""Phase model of a UHF RFID tag read by a monostatic reader (Section III, eqs. 3–6 and 11).

Conventions (used by every module of this package):

- Round-trip phase (eq. 3): φ = −(4π/λ)·d + φ₀, with d the antenna–tag distance and φ₀ the
  constant "dc" terms (cable, tag, reader), which cancel in a difference. ``k = 4π/λ`` is the
  phase slope in rad per metre of range; λ = c / f from the carrier frequency f (865–928 MHz:
  ETSI 865–868 MHz, FCC 902–928 MHz).
- The reader reports φ wrapped into (0, P] with a period P of π or 2π (``wrap_period``): the
  Sargas reader of the paper wraps into (0, π], others into (0, 2π].
- The step's phase difference dφ follows eq. 6: dφ = −(4π/λ)(|S| − |E|) = k(|E| − |S|), positive
  when the step took the user away from the tag. With eq. 3 this is the *negative* of the
  unwrapped phase change, dφ = −(φ_E − φ_S); ``signal.process_move`` returns it in this sign.
- s_θ is the hardware phase noise of one read (rad), "the variability of measured data at a fixed
  set-up" (Section VI).

Reader conventions (the defaults are the paper's):

- ``convention``: 'paper' is eq. 3, the phase *falls* with distance (sign s = −1). 'llrp' is what
  LLRP/Impinj-class readers report: the phase *rises* with distance, φ = +(4π/λ)·d + φ₀ (s = +1;
  a commercial reader's fitted slope was +1.05 × 4π/λ). In both, φ = s·k·d + φ₀ and the step's dφ
  keeps eq. 6's sign: dφ = k(|E| − |S|) = s·(φ_E − φ_S). Only the reader side (the simulator and
  ``signal``) uses s; the filter sees eq. 6 either way.
- Per-read carrier (frequency hopping): a read on carrier f_c has k_c = 4π f_c / c (``k_at``). The
  model's ``carrier_hz`` is the reference carrier: dφ is always expressed as k_ref·Δd with k_ref =
  ``k``, which is what eq. 22 in the filter uses.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

SPEED_OF_LIGHT = 299_792_458.0
CARRIER_RANGE_HZ = (865e6, 928e6)
WRAP_PERIODS = (math.pi, 2.0 * math.pi)
CONVENTIONS = {'paper': -1.0, 'llrp': 1.0}   # sign s of φ = s·k·d + φ₀


@dataclass(frozen=True)
class PhaseModel:
    """Carrier frequency, wrap period and per-read phase noise of the reader."""

    carrier_hz: float = 866.3e6        # an ETSI channel (865.7/866.3/866.9/867.5 MHz)
    wrap_period: float = math.pi       # π (Sargas, as in the paper) or 2π
    s_theta: float = math.radians(5.5)  # per-read phase noise (rad), Section VI
    convention: str = 'paper'          # 'paper' (eq. 3: falls with distance) or 'llrp' (rises)

    def __post_init__(self) -> None:
        lo, hi = CARRIER_RANGE_HZ
        if not (lo <= self.carrier_hz <= hi):
            raise ValueError(f'carrier_hz must be within {lo / 1e6:g}–{hi / 1e6:g} MHz, '
                             f'got {self.carrier_hz / 1e6:g} MHz')
        if not any(math.isclose(self.wrap_period, p) for p in WRAP_PERIODS):
            raise ValueError(f'wrap_period must be π or 2π, got {self.wrap_period!r}')
        if not (self.s_theta >= 0.0 and math.isfinite(self.s_theta)):
            raise ValueError(f's_theta must be finite and >= 0, got {self.s_theta!r}')
        if self.convention not in CONVENTIONS:
            raise ValueError(f'convention must be one of {tuple(CONVENTIONS)}, got {self.convention!r}')

    @classmethod
    def with_wrap(cls, wrap: str | float, **kw) -> PhaseModel:
        """``wrap`` as 'pi', '2pi' or the period in rad."""
        if isinstance(wrap, str):
            table = {'pi': math.pi, '2pi': 2.0 * math.pi}
            if wrap not in table:
                raise ValueError(f"wrap must be 'pi' or '2pi', got {wrap!r}")
            wrap = table[wrap]
        return cls(wrap_period=float(wrap), **kw)

    @property
    def wavelength(self) -> float:
        """λ = c / f (m); 0.346 m at 866.3 MHz."""
        return SPEED_OF_LIGHT / self.carrier_hz

    @property
    def k(self) -> float:
        """4π/λ: phase change per metre of antenna–tag distance (rad/m); ≈ 36.3 at 866.3 MHz."""
        return 4.0 * math.pi / self.wavelength

    @property
    def sign(self) -> float:
        """s of φ = s·k·d + φ₀: −1 for the paper's eq. 3, +1 for LLRP readers."""
        return CONVENTIONS[self.convention]

    @staticmethod
    def k_at(carrier_hz: np.ndarray | float) -> np.ndarray:
        """4π f / c for each carrier (rad/m)."""
        return 4.0 * math.pi * np.asarray(carrier_hz, dtype=float) / SPEED_OF_LIGHT

    def phase(self, d: np.ndarray | float, offset: float = 0.0, carrier_hz: np.ndarray | float | None = None
              ) -> np.ndarray:
        """Unwrapped round-trip phase s·(4π/λ)·d + φ₀ (eq. 3 for s = −1), at ``carrier_hz`` (per read) if given."""
        k = self.k if carrier_hz is None else self.k_at(carrier_hz)
        if self.sign < 0:
            return -k * np.asarray(d, dtype=float) + offset
        return k * np.asarray(d, dtype=float) + offset

    def wrap(self, phi: np.ndarray | float) -> np.ndarray:
        """Wrap into (0, P]: P itself stays P, 0 maps to P."""
        p = self.wrap_period
        return p - np.mod(-np.asarray(phi, dtype=float), p)

    def measured_phase(self, d: np.ndarray | float, offset: float = 0.0) -> np.ndarray:
        """What a noiseless reader reports at distance ``d``: wrap(eq. 3)."""
        return self.wrap(self.phase(d, offset))

    def dphi(self, start_xy: np.ndarray, end_xy: np.ndarray) -> np.ndarray:
        """Geometric phase difference of a step (eq. 6 without θ_d), tag at the origin.

        dφ = −(4π/λ)(|S| − |E|); positions (..., 2).
        """
        s = np.linalg.norm(np.asarray(start_xy, dtype=float), axis=-1)
        e = np.linalg.norm(np.asarray(end_xy, dtype=float), axis=-1)
        return -self.k * (s - e)

    def dphi_noise_std(self, s_r: float, s_theta_step: float | None = None) -> float:
        """Standard deviation of the dφ noise of eq. 11: √(½ (4π/λ)² s_r² + s_θ²).

        ``s_theta_step`` is the noise of the step's dφ (θ_d of eq. 6); default ``s_theta``.
        """
        st = self.s_theta if s_theta_step is None else s_theta_step
        return math.sqrt(0.5 * (self.k * s_r) ** 2 + st**2)
