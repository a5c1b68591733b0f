"""Parameters of the RFID nodes under the names users set, and the core configurations they make.

``PhaseParams`` (the reader's and the guidance's, keep them equal in a scenario) give the phase
model (``phase_model``); the guidance's filter parameters give ``track_core.rfid.pf.PFParams``
(``pf_config``): ``*_deg`` are its radians in degrees and ``reinit_factor`` 0 is its None (never).
Every default is the core's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from track_core.rfid.pf import PFParams
from track_core.rfid.phase import PhaseModel
from track_nodes.base import ParameterError, param

_PH = PhaseModel()
WRAPS = {'pi': math.pi, '2pi': 2.0 * math.pi}  # the ``wrap`` parameter -> PhaseModel.wrap_period


@dataclass
class PhaseParams:
    """The phase model's parameters; the reader's and the guidance's parameters extend these."""

    carrier_hz: float = param(_PH.carrier_hz, 'reader carrier frequency f, λ = c/f [Hz]', 865e6, 928e6)
    wrap: str = param(next(k for k, v in WRAPS.items() if v == _PH.wrap_period), 'wrap period P of the reported '
                      'phase: (0, π] (the paper\'s reader) or (0, 2π]', choices=tuple(WRAPS))
    s_theta_deg: float = param(math.degrees(_PH.s_theta), 'per-read phase noise s_θ (Section VI: 5.5°) [deg]',
                               0.0, 90.0)
    convention: str = param(_PH.convention, 'phase sign: paper (eq. 3, falls with distance) or llrp (rises, '
                            'LLRP/Impinj)', choices=('paper', 'llrp'))


def phase_model(p) -> PhaseModel:
    """The phase model of a node's ``PhaseParams`` ``p``."""
    return PhaseModel.with_wrap(p.wrap, carrier_hz=p.carrier_hz, s_theta=math.radians(p.s_theta_deg),
                                convention=p.convention)


def pf_config(p) -> PFParams:
    """The filter's configuration from the guidance's parameters ``p``; the core's check, one line."""
    try:
        return PFParams(n_particles=p.n_particles, s_step=p.s_step, s_r=p.s_r, s_a=math.radians(p.s_a_deg),
                        beam_width=math.radians(p.beam_width_deg), suggestion=p.suggestion, weighting=p.weighting,
                        reinit_factor=p.reinit_factor if p.reinit_factor > 0 else None)
    except ValueError as exc:
        raise ParameterError(f'invalid filter parameters: {exc}') from None
