"""A shard's region: which tracks a fusion shard holds and which pairs it answers for.

Fusion of a large picture is split by space: shard k holds the tracks whose reports fall inside
its rectangle widened by ``margin`` (``contains``) and publishes the pairs whose midpoint lies in
its rectangle (``owns``; half-open, so rectangles that tile the plane give every pair exactly one
owner). A shard drops a track the moment one of its reports falls outside (the associator's
``forget``): the track re-enters later as a new track, with nothing kept from before.

Why the associations then equal one node's: a pair the gate passes has overlapping 2σ ellipses,
so its tracks are at most r_i + r_j ≤ 2 r_max apart, each within r_max of the midpoint. A pair's
window covers its last ``window`` scored instants (``window``/rate seconds), and a report is used
for up to ``stale_after`` seconds. If ``margin`` ≥ r_max + v_max · (``window``/rate +
``stale_after``) (``margin_needed``), both tracks of an owned pair have been inside the widened
rectangle over the whole window: the shard scored them at the same instants as one node, so it
holds the same window and gives the same score, combination and verdict. Pairs younger than a
window were inside since both tracks began. The bound assumes the tracks' speeds stay below
v_max and their 2σ semi-major axes below r_max; ``track-bench fusion-shards`` measures the
difference.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Region:
    """Rectangle [xmin, xmax) × [ymin, ymax) (bounds may be ±inf) and the margin of held tracks [m]."""

    xmin: float = -math.inf
    xmax: float = math.inf
    ymin: float = -math.inf
    ymax: float = math.inf
    margin: float = 0.0

    def __post_init__(self) -> None:
        if not (self.xmin < self.xmax and self.ymin < self.ymax) or not self.margin >= 0 or math.isnan(self.margin):
            raise ValueError(f'region needs xmin < xmax, ymin < ymax and margin >= 0; got {self}')

    @classmethod
    def parse(cls, bounds, margin: float) -> Region:
        """``[xmin, xmax, ymin, ymax]`` (a parameter) → Region; an empty list → the whole plane."""
        b = [float(v) for v in bounds]
        if not b:
            return cls(margin=float(margin))
        if len(b) != 4:
            raise ValueError(f'region must be [xmin, xmax, ymin, ymax] or empty, got {b}')
        return cls(*b, margin=float(margin))

    def contains(self, x: float, y: float) -> bool:
        """Whether a report at (x, y) is held: inside the rectangle widened by the margin."""
        m = self.margin
        return self.xmin - m <= x < self.xmax + m and self.ymin - m <= y < self.ymax + m

    def contains_all(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """``contains`` of many reports at once (NaN: False)."""
        m = self.margin
        x, y = np.asarray(x, float), np.asarray(y, float)
        return (x >= self.xmin - m) & (x < self.xmax + m) & (y >= self.ymin - m) & (y < self.ymax + m)

    def owns(self, mu_a: np.ndarray, mu_b: np.ndarray) -> np.ndarray:
        """Per pair (positions (n, 2) each): whether its midpoint lies in the rectangle."""
        mid = 0.5 * (np.asarray(mu_a, float).reshape(-1, 2) + np.asarray(mu_b, float).reshape(-1, 2))
        return ((mid[:, 0] >= self.xmin) & (mid[:, 0] < self.xmax)
                & (mid[:, 1] >= self.ymin) & (mid[:, 1] < self.ymax))


class ShardInput:
    """Which reports a shard takes: ``route`` → 'hold' (use it), 'drop' (forget the track now) or 'skip'."""

    def __init__(self, region: Region) -> None:
        self.region = region
        self.held: set[str] = set()
        self.outside = 0          # reports outside the widened rectangle (other shards' tracks)

    def route(self, track_id: str, x: float, y: float) -> str:
        if self.region.contains(x, y):
            self.held.add(track_id)
            return 'hold'
        self.outside += 1
        if track_id in self.held:
            self.held.discard(track_id)
            return 'drop'
        return 'skip'

    def clear(self) -> None:
        self.held.clear()


def margin_needed(r_max: float, v_max: float, window: int, rate: float, stale_after: float) -> float:
    """The margin [m] above which a shard's owned pairs equal one node's (module docstring)."""
    return r_max + v_max * (window / rate + stale_after)


def grid(xmin: float, xmax: float, ymin: float, ymax: float, nx: int, ny: int, margin: float) -> list[Region]:
    """nx × ny regions tiling the plane: the given box cut evenly, the outer cells open to ±inf."""
    xs = np.linspace(xmin, xmax, nx + 1)
    ys = np.linspace(ymin, ymax, ny + 1)
    xs[0], xs[-1], ys[0], ys[-1] = -math.inf, math.inf, -math.inf, math.inf
    return [Region(float(xs[i]), float(xs[i + 1]), float(ys[j]), float(ys[j + 1]), margin)
            for j in range(ny) for i in range(nx)]
