"""Parameters that the reader and the guidance share: the phase model (keep them equal in a scenario)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from track_core.rfid.phase import PhaseModel
from track_nodes.base import param

_PH = PhaseModel()


@dataclass
class PhaseParams:
    """The phase model's parameters; the reader's and the guidance's parameters extend these."""

    carrier_hz: float = param(_PH.carrier_hz, 'reader carrier frequency f, λ = c/f [Hz]', 865e6, 928e6)
    wrap: str = param('pi', 'wrap period P of the reported phase: (0, π] (the paper\'s reader) or (0, 2π]',
                      choices=('pi', '2pi'))
    s_theta_deg: float = param(math.degrees(_PH.s_theta), 'per-read phase noise s_θ (Section VI: 5.5°) [deg]',
                               0.0, 90.0)
    convention: str = param(_PH.convention, 'phase sign: paper (eq. 3, falls with distance) or llrp (rises, '
                            'LLRP/Impinj)', choices=('paper', 'llrp'))
