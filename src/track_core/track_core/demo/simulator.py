"""Seeded constant-velocity truth with noisy position reports (state [x, ẋ, y, ẏ])."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from track_core.filters import check_covariance, cv_process_noise, cv_transition


@dataclass
class CVTarget:
    """A CV target sampled every ``T`` seconds, reporting its position with noise ``R``.

    ``x0`` is (4,) for one target or (M, 4) for M independent Monte-Carlo copies, which
    then advance together in one vectorised step.

    ``t`` counts as ``k·T`` from the step index, never from a clock, so a seed reproduces
    the stamps and values bit for bit whatever the executor timing.
    """

    x0: np.ndarray
    T: float = 0.1
    q_s: float = 0.05
    R: np.ndarray = field(default_factory=lambda: np.diag([4.0, 4.0]))
    k: int = 0
    _t_base: float = field(default=0.0, init=False, repr=False)  # t and k at the last set_period
    _k_base: int = field(default=0, init=False, repr=False)

    def __post_init__(self) -> None:
        self.x = np.asarray(self.x0, dtype=float).copy()
        if self.x.shape[-1:] != (4,) or self.x.ndim > 2 or not np.all(np.isfinite(self.x)):
            raise ValueError(f'x0 must be 4 finite numbers [x, vx, y, vy], got {self.x0!r}')
        if not self.T > 0:
            raise ValueError(f'T must be > 0, got {self.T}')
        if not self.q_s >= 0:
            raise ValueError(f'q_s must be >= 0, got {self.q_s}')
        self.R = check_covariance(self.R, 'R', definite=True)
        self._F = cv_transition(self.T)
        self._Q = cv_process_noise(self.T, self.q_s)

    def set_period(self, T: float) -> None:
        """Sample every ``T`` from now on (the state is kept; ``t`` goes on from where it is)."""
        if not T > 0:
            raise ValueError(f'T must be > 0, got {T}')
        self._t_base = self.t
        self._k_base = self.k
        self.T, self._F, self._Q = T, cv_transition(T), cv_process_noise(T, self.q_s)

    @property
    def t(self) -> float:
        return self._t_base + (self.k - self._k_base) * self.T

    def step(self, rng: np.random.Generator) -> np.ndarray:
        """Advance one interval T; returns the new true state."""
        batch = self.x.shape[:-1]
        w = rng.multivariate_normal(np.zeros(4), self._Q, size=batch) if self.q_s > 0 else 0.0
        self.x = self.x @ self._F.T + w
        self.k += 1
        return self.x.copy()

    def report(self, rng: np.random.Generator) -> np.ndarray:
        """Noisy position [x, y] of the current state(s), shape (..., 2)."""
        return self.x[..., [0, 2]] + rng.multivariate_normal(np.zeros(2), self.R, size=self.x.shape[:-1])
