"""Parameters that the reader and the guidance share: the phase model (keep them equal in a scenario)."""

from __future__ import annotations

import math

from track_core.rfid.phase import PhaseModel
from track_nodes.base import Param

_PH = PhaseModel()

PHASE_PARAMS = (
    Param('carrier_hz', _PH.carrier_hz, 'reader carrier frequency f, λ = c/f [Hz]', 865e6, 928e6),
    Param('wrap', 'pi', 'wrap period P of the reported phase: (0, π] (the paper\'s reader) or (0, 2π]',
          choices=('pi', '2pi')),
    Param('s_theta_deg', math.degrees(_PH.s_theta), 'per-read phase noise s_θ (Section VI: 5.5°) [deg]', 0.0, 90.0),
    Param('convention', _PH.convention, 'phase sign: paper (eq. 3, falls with distance) or llrp (rises, LLRP/Impinj)',
          choices=('paper', 'llrp')),
)
