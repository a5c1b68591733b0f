"""``AssociatorConfig``: every setting of ``PairAssociator``, with its defaults written once.

The defaults are the ``fusion`` node's (what a live run uses); the node declares them under its own
parameter names (``track_nodes.fusion.params``) and an offline replay builds the same object from a
scenario file, so replay and live run agree. What each setting does: ``associator``'s docstring.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from numbers import Integral, Real

from track_core.geofeasibility.track import MEANS, THRESHOLD, check_floor

METHODS = ('exact', 'glr', 'glr_thresholded', 'mc')


@dataclass(frozen=True)
class AssociatorConfig:
    """Scoring (``method``, ``n_samples``, ``seed`` of the mc draws, ``gate``, ``same_source_pairs``), the
    track-level rule (``combine`` over ``window`` instants, ``floor`` ε, prior ν = ``prior_weight`` at
    s̄ = ``prior_score``, ``threshold``, ``release_ratio`` ρ), the track table (``stale_after``,
    ``max_prediction``, ``q_s``) and the instants: ``stamp_rate`` (None: the caller's ticks; else the
    data's k/rate, waiting at most ``stamp_max_wait`` of data time for a silent stream)."""

    method: str = 'exact'
    threshold: float = THRESHOLD
    combine: str = 'geometric'
    window: int = 10
    floor: float = 0.0
    release_ratio: float = 1.0
    prior_weight: float = 0.0
    prior_score: float = 1.0
    n_samples: int = 500
    seed: int = 0
    same_source_pairs: bool = False
    gate: bool = True
    stale_after: float = 2.0
    max_prediction: float = 10.0
    q_s: float = 0.1
    stamp_rate: float | None = None
    stamp_max_wait: float = 30.0

    def __post_init__(self) -> None:
        _need(self.method in METHODS, 'method', self.method, f'one of {", ".join(METHODS)}')
        _need(self.combine in MEANS, 'combine', self.combine, f'one of {", ".join(MEANS)} (the mean)')
        _need(_number(self.threshold) and 0.0 <= self.threshold <= 1.0, 'threshold', self.threshold, 'in [0, 1]')
        _need(_integer(self.window) and self.window >= 1, 'window', self.window, 'an integer >= 1')
        check_floor(self.floor)
        _need(_number(self.release_ratio) and 0.0 < self.release_ratio <= 1.0, 'release_ratio', self.release_ratio,
              'in (0, 1]')
        _need(_number(self.prior_weight) and self.prior_weight >= 0.0, 'prior_weight', self.prior_weight, '>= 0')
        _need(_number(self.prior_score) and 0.0 < self.prior_score <= 1.0, 'prior_score', self.prior_score,
              'in (0, 1]')
        _need(_integer(self.n_samples) and self.n_samples >= 1, 'n_samples', self.n_samples, 'an integer >= 1')
        _need(_integer(self.seed) and self.seed >= 0, 'seed', self.seed, 'an integer >= 0')
        for name in ('stale_after', 'max_prediction'):
            v = getattr(self, name)
            _need(_number(v) and v > 0.0, name, v, 'a number > 0 [s]')
        _need(_number(self.q_s) and self.q_s >= 0.0, 'q_s', self.q_s, 'a number >= 0 [m²/s³]')
        _need(self.stamp_rate is None or (_number(self.stamp_rate) and self.stamp_rate > 0.0), 'stamp_rate',
              self.stamp_rate, 'None or a number > 0 [Hz]')
        _need(isinstance(self.stamp_max_wait, Real) and self.stamp_max_wait >= 0.0, 'stamp_max_wait',
              self.stamp_max_wait, 'a number >= 0 [s]')


def _number(v) -> bool:
    return isinstance(v, Real) and not isinstance(v, bool) and math.isfinite(v)


def _integer(v) -> bool:
    return isinstance(v, Integral) and not isinstance(v, bool)


def _need(ok: bool, name: str, value, allowed: str) -> None:
    if not ok:
        raise ValueError(f'{name} must be {allowed}, got {value!r}')
