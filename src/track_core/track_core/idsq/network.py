"""Sensor layout and network rules of §5.1.

- Connectivity: a sensor talks to every sensor within ``comm_range`` (40 m); "if there are less
  than two sensors in range" it talks to the two nearest instead (so a sensor always has at
  least two neighbours). ``SensorLayout.neighbours`` holds these lists (no leader history).
- Triplet rule (§5.1: "the previous leader is not included in the neighborhood of the current
  leader"): the leader's neighbourhood N — the candidates it scores — is built by the same
  "40 m, or else the two nearest" rule *over the sensors other than the previous leader*
  (exclude first, then "at least two": this order matches Table 4's "avg. neigh. size"; the
  figures: docs/results/idsq.md). A node therefore needs the positions of its in-range sensors
  *and* of its nearest few (the shared layout has all). If no sensor but the previous leader
  exists, the previous leader is allowed back rather than stopping the track.
- Start (§5.1): the acoustic-amplitude sensor with the highest amplitude reading at t = 0.
  With no acoustic sensor (100 % DOA, Table 5) "highest amplitude" is undefined; we use the
  amplitude every sensor's microphones hear (DOA arrays are microphones too).
- Table 4's "neighborhood size" is |N|, the number of candidates after the triplet rule
  (``LeaderStepResult.neighbourhood_size``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class SensorLayout:
    """Sensor positions (K, 2) in ENU metres, a DOA flag per sensor, and the neighbour lists."""

    positions: np.ndarray
    is_doa: np.ndarray
    comm_range: float = 40.0
    min_neighbours: int = 2
    neighbours: tuple[np.ndarray, ...] = field(default=(), compare=False)

    def __post_init__(self) -> None:
        pos = np.asarray(self.positions, dtype=float)
        doa = np.asarray(self.is_doa, dtype=bool)
        if pos.ndim != 2 or pos.shape[1] != 2 or pos.shape[0] < 2:
            raise ValueError(f'positions shape={pos.shape} must be (K, 2) with K >= 2')
        if not np.all(np.isfinite(pos)):
            raise ValueError('positions must be finite')
        if doa.shape != (pos.shape[0],):
            raise ValueError(f'is_doa shape={doa.shape} must be ({pos.shape[0]},)')
        if not (np.isfinite(self.comm_range) and self.comm_range > 0):
            raise ValueError(f'comm_range={self.comm_range} must be finite and > 0 m')
        if not 1 <= self.min_neighbours < pos.shape[0]:
            raise ValueError(f'min_neighbours={self.min_neighbours} must be in [1, {pos.shape[0] - 1}]')
        object.__setattr__(self, 'positions', pos)
        object.__setattr__(self, 'is_doa', doa)
        if not self.neighbours:
            object.__setattr__(self, 'neighbours', build_neighbours(pos, self.comm_range, self.min_neighbours))

    @property
    def n(self) -> int:
        return int(self.positions.shape[0])


def build_neighbours(positions: np.ndarray, comm_range: float = 40.0, min_count: int = 2) -> tuple[np.ndarray, ...]:
    """Per sensor: indices within ``comm_range``, or the ``min_count`` nearest if fewer are in range."""
    positions = np.asarray(positions, dtype=float)
    return tuple(in_range_or_nearest(positions, k, (), comm_range, min_count)  # K rows, not cells
                 for k in range(positions.shape[0]))


def in_range_or_nearest(positions: np.ndarray, k: int, exclude: np.ndarray | list[int] = (),
                        comm_range: float = 40.0, min_count: int = 2) -> np.ndarray:
    """Sorted indices within ``comm_range`` of sensor ``k``, or its ``min_count`` nearest if fewer are
    in range, among the sensors other than ``k`` and ``exclude``."""
    d = np.hypot(*(np.asarray(positions, dtype=float) - positions[k]).T)
    d[k] = np.inf
    d[np.asarray(exclude, dtype=np.int64)] = np.inf
    order = np.argsort(d, kind='stable')
    order = order[np.isfinite(d[order])]
    near = order[d[order] <= comm_range]
    return np.sort(near if near.size >= min_count else order[:min_count])


def candidates(layout: SensorLayout, leader: int, previous: int | None) -> np.ndarray:
    """The leader's neighbourhood under the triplet rule (see the module docstring): the sensors
    within range, or else the two nearest, among those other than the previous leader."""
    if previous is None or previous == leader:
        return layout.neighbours[leader]
    c = in_range_or_nearest(layout.positions, leader, [previous], layout.comm_range, layout.min_neighbours)
    return c if c.size else layout.neighbours[leader]


def handoff_targets(layout: SensorLayout, leader: int) -> np.ndarray:
    """Sorted indices of every sensor ``leader`` may hand off to: the union over all previous leaders of
    ``candidates(layout, leader, previous)``, which may reach beyond ``neighbours[leader]``.

    Excluding one sensor from "within range, or else the ``min_neighbours`` nearest" can only
    promote the next nearest sensor, so the union is the same rule with ``min_neighbours + 1``
    (a node opens its handoff/ack endpoints for these at layout time).
    """
    return in_range_or_nearest(layout.positions, leader, (), layout.comm_range, layout.min_neighbours + 1)


def start_leader(layout: SensorLayout, amplitudes: np.ndarray) -> int:
    """§5.1: the acoustic sensor with the highest amplitude reading (any sensor if none is acoustic)."""
    amp = np.asarray(amplitudes, dtype=float)
    if amp.shape != (layout.n,):
        raise ValueError(f'amplitudes shape={amp.shape} must be ({layout.n},)')
    pool = np.flatnonzero(~layout.is_doa)
    if pool.size == 0:
        pool = np.arange(layout.n)
    return int(pool[np.argmax(amp[pool])])
