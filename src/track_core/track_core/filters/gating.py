"""Innovation gating: refuse a measurement whose Mahalanobis distance from the prediction is implausible.

A report fused without a gate moves a track wherever any publisher puts it: a second publisher
1000 m off drags the estimate away. The gate compares d² = νᵀ S⁻¹ ν (innovation ν, its covariance
S = H P Hᵀ + R) with the χ² quantile of ``probability`` for the measurement dimension; for a
consistent filter an honest report falls outside with probability 1 − ``probability``.

A gate must never lock a track out. ``InnovationGate`` therefore

- gates only a meaningful prediction: the caller asks only once its filter is initialised, and
  after a gap longer than ``max_gap`` s the report is let through (the filter's covariance has
  grown, but a model held that long is not worth defending);
- counts consecutive rejections: after ``max_misses`` of them in a row, with no report accepted for
  ``lost_time`` s, the track is taken as lost and the caller re-initialises its filter on the next
  report, so a target that really jumped (or a track predicted from a stale run) is found again.
  Misses alone are no evidence: a rogue publisher ten times faster than the honest source fills
  the gap between two honest reports with ten misses. The time is: while the honest source keeps
  coming, no report is ever that late, so the rogue never takes over;
- keeps the outcome of the last ``window`` gated reports, so a caller can say when one source is
  rejected persistently (``persistent``).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

import numpy as np
from scipy.linalg import cho_factor, cho_solve
from scipy.stats import chi2


def gate_threshold(probability: float, dim: int) -> float:
    """χ² quantile: d² below it for a fraction ``probability`` of honest ``dim``-dimensional innovations."""
    if not 0.0 < probability < 1.0:
        raise ValueError(f'gate probability must be in (0, 1), got {probability}')
    return float(chi2.ppf(probability, dim))


def innovation_d2(nu: np.ndarray, S: np.ndarray) -> float:
    """νᵀ S⁻¹ ν by a Cholesky solve; ``inf`` when S is not positive definite."""
    nu = np.asarray(nu, dtype=float)
    try:
        factor = cho_factor(np.asarray(S, dtype=float), lower=True, check_finite=True)
    except (np.linalg.LinAlgError, ValueError):
        return math.inf
    return float(nu @ cho_solve(factor, nu))


@dataclass
class GateDecision:
    accepted: bool
    d2: float
    threshold: float
    reinitialise: bool = False  # the track was lost: fuse this report as a new track

    def reason(self) -> str:
        return (f'innovation gate: Mahalanobis distance² {self.d2:.4g} > {self.threshold:.4g} '
                f'(report far from the track; another publisher?)')


@dataclass
class InnovationGate:
    probability: float = 0.9999
    dim: int = 2
    max_misses: int = 10
    max_gap: float = 30.0
    window: int = 20
    lost_time: float = 0.0  # s without an accepted report before consecutive misses mean the track is lost
    misses: int = 0  # consecutive rejections
    _recent: deque = field(default_factory=deque, repr=False)

    def __post_init__(self) -> None:
        self.threshold = gate_threshold(self.probability, self.dim)
        if self.max_misses < 1 or self.window < 1 or not self.max_gap > 0 or not 0.0 <= self.lost_time < math.inf:
            raise ValueError(f'invalid gate {self}')

    def set_probability(self, probability: float) -> None:
        self.threshold = gate_threshold(probability, self.dim)
        self.probability = probability

    def check(self, nu: np.ndarray, S: np.ndarray, gap: float) -> GateDecision:
        """Decide on one report with innovation ``nu`` (covariance ``S``), ``gap`` s after the last fused one."""
        d2 = innovation_d2(nu, S)
        if gap > self.max_gap:
            return self._record(GateDecision(True, d2, self.threshold, reinitialise=True))
        if d2 <= self.threshold:
            return self._record(GateDecision(True, d2, self.threshold))
        self.misses += 1
        if self.misses >= self.max_misses and gap >= self.lost_time:
            return self._record(GateDecision(True, d2, self.threshold, reinitialise=True))
        return self._record(GateDecision(False, d2, self.threshold))

    def _record(self, decision: GateDecision) -> GateDecision:
        if decision.accepted:
            self.misses = 0
        self._recent.append(decision.accepted)
        while len(self._recent) > self.window:
            self._recent.popleft()
        return decision

    @property
    def rejected_share(self) -> float:
        """Fraction of the last ``window`` gated reports that were rejected (0 before any)."""
        return self._recent.count(False) / len(self._recent) if self._recent else 0.0

    @property
    def persistent(self) -> bool:
        """At least half of the last ``window`` gated reports were rejected (with a full window)."""
        return len(self._recent) >= self.window and self._recent.count(False) * 2 >= self.window

    def reset(self) -> None:
        self.misses = 0
        self._recent.clear()
