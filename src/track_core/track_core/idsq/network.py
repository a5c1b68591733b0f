"""Sensor layout and network rules of §5.1.

- Connectivity: a sensor talks to every sensor within ``comm_range`` (40 m); "if there are less
  than two sensors in range" it talks to the two nearest instead (so a sensor always has at
  least two neighbours). Neighbour lists are symmetric-agnostic: built per sensor.
- Triplet rule: the previous leader is removed from the current leader's candidates.
  If that leaves no candidate (a sensor whose only neighbour is the previous leader cannot
  occur with the two-nearest rule, but a layout given from outside might), the previous leader
  is allowed back rather than stopping the track.
- Start (§5.1): the acoustic-amplitude sensor with the highest amplitude reading at t = 0.
  With no acoustic sensor (100 % DOA, Table 5) "highest amplitude" is undefined; we use the
  amplitude every sensor's microphones hear (DOA arrays are microphones too).
- Table 4's "neighborhood size" is |N| of the leader *before* the triplet exclusion (the paper's
  2.0 at K = 24 matches that: with 4 columns 37.5 m apart almost every sensor has exactly 2).
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
    d = np.linalg.norm(positions[:, None, :] - positions[None, :, :], axis=-1)
    np.fill_diagonal(d, np.inf)
    order = np.argsort(d, axis=1, kind='stable')
    out = []
    for k in range(positions.shape[0]):  # K rows, not cells or particles
        near = order[k][d[k, order[k]] <= comm_range]
        out.append(near if near.size >= min_count else order[k][:min_count])
    return tuple(np.sort(a) for a in out)


def candidates(layout: SensorLayout, leader: int, previous: int | None) -> np.ndarray:
    """The leader's neighbours minus the previous leader (triplet rule)."""
    nb = layout.neighbours[leader]
    if previous is None:
        return nb
    c = nb[nb != previous]
    return c if c.size else nb


def start_leader(layout: SensorLayout, amplitudes: np.ndarray) -> int:
    """§5.1: the acoustic sensor with the highest amplitude reading (any sensor if none is acoustic)."""
    amp = np.asarray(amplitudes, dtype=float)
    if amp.shape != (layout.n,):
        raise ValueError(f'amplitudes shape={amp.shape} must be ({layout.n},)')
    pool = np.flatnonzero(~layout.is_doa)
    if pool.size == 0:
        pool = np.arange(layout.n)
    return int(pool[np.argmax(amp[pool])])
