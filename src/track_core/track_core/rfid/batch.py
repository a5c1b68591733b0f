"""Batch least-squares baseline: the tag position from all the MOVEs and their dφ at once.

The particle filter (``pf``) folds the MOVEs in one at a time. This baseline uses the same
information in one go: the path the guidance believes in (commanded step lengths along the
headings given by the reported turns, eq. 19–20 without noise, from the first MOVE's start at the
origin facing +x) and the measured dφ of each MOVE. The tag T minimises

    J(T) = Σⱼ (dφⱼ − (4π/λ)(|Eⱼ − T| − |Sⱼ − T|))²       (eq. 6 with the tag at T)

with Sⱼ, Eⱼ the start and end of MOVE j. A MOVE whose dφ is NaN (the reader could not measure it)
still moves the path and adds no term to J. J is evaluated on a grid (vectorised over the cells,
``cell`` metres, ``extent`` metres around the path), and the best cell is refined by Gauss–Newton
(``scipy.optimize.least_squares``, Levenberg–Marquardt), kept when it stays on the grid's square (a
tag far ahead of a short straight path is barely observable and the refinement may run off). A
straight path gives J(T) = J(T′) for the mirror image T′ of T across the walking line, so the fit
reports the mirror too, and ``ambiguous`` when the path is straight to within ``straight_tol`` metres
(the mirror's cost is then the same).

``tag_in_user_frame`` turns a tag position of the path frame into the frame of the user at the
path's end (x forward along the last heading, y left), the frame of ``pf.TagEstimate``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares


@dataclass(frozen=True)
class BatchFit:
    """Result of ``fit_tag``: positions in the path frame (first MOVE's start at the origin, facing +x)."""

    xy: np.ndarray           # (2,) the least-squares tag position
    mirror: np.ndarray       # (2,) its mirror image across the path's line
    cost: float              # J at xy (rad²)
    ambiguous: bool          # the path is straight: the mirror fits as well


def path_from_moves(steps: np.ndarray, turns: np.ndarray, heading0: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Positions (M + 1, 2) and headings (M,) of M MOVEs; ``turns[j]`` is the turn made before MOVE j (eq. 19)."""
    steps, turns = np.asarray(steps, dtype=float), np.asarray(turns, dtype=float)
    head = heading0 + np.cumsum(turns)
    d = steps[:, None] * np.column_stack([np.cos(head), np.sin(head)])
    return np.vstack([np.zeros(2), np.cumsum(d, axis=0)]), head


def _predicted(positions: np.ndarray, tag: np.ndarray, k: float) -> np.ndarray:
    """k(|E − T| − |S − T|) per MOVE for tags (..., 2): shape (..., M)."""
    q = positions - tag[..., None, :]
    r = np.hypot(q[..., 0], q[..., 1])                               # (..., M + 1)
    return k * np.diff(r, axis=-1)


def _line_mirror(positions: np.ndarray, xy: np.ndarray) -> tuple[np.ndarray, float]:
    """Mirror of ``xy`` across the least-squares line of the path, and the path's largest distance from it."""
    c = positions.mean(axis=0)
    _, _, vt = np.linalg.svd(positions - c)
    u = vt[0]
    q = xy - c
    along = (q @ u) * u
    dev = float(np.max(np.abs((positions - c) @ np.array([-u[1], u[0]]))))
    return c + along - (q - along), dev


def fit_tag(positions: np.ndarray, dphi: np.ndarray, k: float, *, extent: float = 15.0, cell: float = 0.2,
            straight_tol: float = 1e-3) -> BatchFit:
    """Least-squares tag position for a path (M + 1, 2) and its M dφ (module doc)."""
    positions, dphi = np.asarray(positions, dtype=float), np.asarray(dphi, dtype=float)
    if positions.ndim != 2 or positions.shape[1] != 2 or positions.shape[0] != dphi.size + 1 or dphi.size < 2:
        raise ValueError(f'need positions (M + 1, 2) and M >= 2 dφ, got {positions.shape} and {dphi.shape}')
    j = np.flatnonzero(np.isfinite(dphi))       # unmeasured MOVEs move the path, add no term
    if j.size < 2:
        raise ValueError(f'need at least 2 finite dφ, got {j.size} of {dphi.size}')
    dphi = dphi[j]
    c = positions.mean(axis=0)
    g = np.arange(-extent, extent + 0.5 * cell, cell)
    best, best_cost = None, math.inf
    for gx in np.array_split(g, max(1, g.size // 100)):      # blocks of grid columns bound the memory
        tags = np.stack(np.meshgrid(c[0] + gx, c[1] + g, indexing='ij'), axis=-1)   # (nx, ny, 2)
        cost = np.sum(np.square(_predicted(positions, tags, k)[..., j] - dphi), axis=-1)
        i = np.unravel_index(int(np.argmin(cost)), cost.shape)
        if cost[i] < best_cost:
            best, best_cost = tags[i], float(cost[i])
    sol = least_squares(lambda tag: _predicted(positions, tag, k)[j] - dphi, best, method='lm')
    inside = bool(np.all(np.abs(sol.x - c) <= extent))      # an ill-posed fit may run off to infinity
    xy = sol.x if inside and 2.0 * sol.cost <= best_cost else best
    cost = float(np.sum(np.square(_predicted(positions, xy, k)[j] - dphi)))
    mirror, dev = _line_mirror(positions, xy)
    return BatchFit(np.asarray(xy, dtype=float), mirror, cost, dev <= straight_tol)


def tag_in_user_frame(xy: np.ndarray, position: np.ndarray, heading: float) -> np.ndarray:
    """A path-frame point in the frame of a user at ``position`` facing ``heading`` (x forward, y left)."""
    q = np.asarray(xy, dtype=float) - np.asarray(position, dtype=float)
    c, s = math.cos(heading), math.sin(heading)
    return np.array([c * q[..., 0] + s * q[..., 1], -s * q[..., 0] + c * q[..., 1]]).T
