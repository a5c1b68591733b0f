"""The motion state a velocity-aware belief carries (``SparseBelief.motion``; beyond the paper).

Plain data, so the grid (which holds it) and the predictions (which update it, ``prediction.py``)
both import it without importing each other.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Motion:
    """Velocity estimate v̂ [m/s] (ENU) carried with a belief, and how many MMSE velocities went into it."""

    velocity: np.ndarray
    count: int = 0

    def __post_init__(self) -> None:
        v = np.asarray(self.velocity, dtype=float).reshape(-1)
        if v.shape != (2,) or not np.all(np.isfinite(v)):
            raise ValueError(f'velocity={self.velocity!r} must be 2 finite numbers [m/s]')
        if int(self.count) != self.count or self.count < 0:
            raise ValueError(f'count={self.count} must be an integer >= 0')
        object.__setattr__(self, 'velocity', v)


NO_MOTION = Motion(np.zeros(2), 0)


@dataclass(frozen=True)
class Bank:
    """Joint belief over (velocity hypothesis j, cell): sorted unique keys j·n_cells + cell and masses (sum 1).

    The hypotheses are the lattice ``bank_velocities(step, v_max)``; ``step`` identifies it on the wire."""

    step: float
    n_hyp: int
    key: np.ndarray
    mass: np.ndarray
