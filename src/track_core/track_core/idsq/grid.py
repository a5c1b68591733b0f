"""Sparse 2-D grid belief (§2.3) and its prediction by a uniform-disk convolution (§2.1, eq. 3).

Interpretations (the paper is terse here):
- Grid: square cells of ``cell`` metres (5 m, §5.1) covering ``[x0, x0 + nx·cell] × [y0, y0 +
  ny·cell]`` in ENU (x east, y north); a cell is its flat index ``iy·nx + ix``, at its centre.
- Belief values are probability *masses* per cell (sum 1), not densities.
- Sparsity (§2.3): after every update and prediction, cells below ``SPARSITY_THRESHOLD`` (0.1 %)
  *of the largest cell mass* are dropped and the rest renormalised. Relative, so the uniform start
  belief is kept whole; for a Gaussian cloud it is the 3.7-σ contour (≈ 99.9 % of the mass). The
  paper gives no value; set by that argument, not fitted (sensitivity: docs/results/idsq.md).
- MMSE estimate (eq. 2) = belief-weighted centroid of the cell centres; spread = weighted
  ‖x̂ − x̂_MMSE‖² (Table 4), the trace of the weighted covariance. ``Estimate.block_spread`` is the
  other reading (plain mean over the stored blocks; ``idsq-table4`` prints both).
- Prediction: p(x⁽ᵗ⁺¹⁾|x⁽ᵗ⁾) is a uniform disk of radius v_max·Δt (§2.1); a cell's kernel weight is
  the fraction of its area inside the disk (supersampled 16 × 16), renormalised; the convolution is
  ``scipy.signal.fftconvolve`` on the support's bounding box padded by the kernel radius, round-off
  clipped to 0; mass pushed outside the field is dropped before renormalising.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import lru_cache

import numpy as np
from scipy.signal import fftconvolve

from track_core.filters import weighted_mean_cov
from track_core.idsq.motion import Bank, Motion

SPARSITY_THRESHOLD = 1e-3
"""Cells with mass < SPARSITY_THRESHOLD × (largest cell mass) are dropped (§2.3)."""


@dataclass(frozen=True)
class GridSpec:
    """Regular grid over the field: origin (south-west corner), cell size and cell counts."""

    x0: float = 0.0
    y0: float = 0.0
    cell: float = 5.0
    nx: int = 30
    ny: int = 50

    def __post_init__(self) -> None:
        if not (np.isfinite(self.cell) and self.cell > 0):
            raise ValueError(f'cell={self.cell} must be a finite length > 0 m')
        if not (np.isfinite(self.x0) and np.isfinite(self.y0)):
            raise ValueError(f'origin=({self.x0}, {self.y0}) must be finite')
        for name in ('nx', 'ny'):
            v = getattr(self, name)
            if int(v) != v or not 1 <= v <= 65535:
                raise ValueError(f'{name}={v} must be an integer in [1, 65535]')

    @classmethod
    def for_field(cls, width: float = 150.0, height: float = 250.0, cell: float = 5.0) -> GridSpec:
        """The grid covering a ``width`` × ``height`` m field with origin (0, 0)."""
        if not (width > 0 and height > 0):
            raise ValueError(f'field={width}x{height} must have both sides > 0 m')
        return cls(0.0, 0.0, cell, int(np.ceil(width / cell)), int(np.ceil(height / cell)))

    @property
    def n_cells(self) -> int:
        return self.nx * self.ny

    def centers(self, idx: np.ndarray) -> np.ndarray:
        """(n, 2) ENU centres of flat cell indices ``idx``."""
        idx = np.asarray(idx)
        iy, ix = np.divmod(idx, self.nx)
        return np.stack([self.x0 + (ix + 0.5) * self.cell, self.y0 + (iy + 0.5) * self.cell], axis=-1)

    def index_of(self, xy: np.ndarray) -> np.ndarray:
        """Flat index of the cell containing each point (points are clipped into the field)."""
        xy = np.atleast_2d(np.asarray(xy, dtype=float))
        ix = np.clip(np.floor((xy[:, 0] - self.x0) / self.cell).astype(int), 0, self.nx - 1)
        iy = np.clip(np.floor((xy[:, 1] - self.y0) / self.cell).astype(int), 0, self.ny - 1)
        return iy * self.nx + ix


@dataclass(frozen=True)
class SparseBelief:
    """Belief p(x⁽ᵗ⁾|z̄⁽ᵗ⁾) on a grid: sorted unique flat indices and their masses (sum 1)."""

    grid: GridSpec
    idx: np.ndarray
    mass: np.ndarray
    motion: Motion | Bank | None = field(default=None, compare=False)  # motion state (prediction.py)

    def with_motion(self, motion: Motion | Bank | None) -> SparseBelief:
        """The same cells and masses carrying ``motion`` (see ``prediction.py``)."""
        return self if motion is self.motion else replace(self, motion=motion)

    @property
    def size(self) -> int:
        """Number of stored cells (Table 4's "belief size")."""
        return int(self.idx.size)

    def centers(self) -> np.ndarray:
        return self.grid.centers(self.idx)

    def dense(self) -> np.ndarray:
        """(ny, nx) array of masses, zero outside the support."""
        out = np.zeros(self.grid.n_cells)
        out[self.idx] = self.mass
        return out.reshape(self.grid.ny, self.grid.nx)


@dataclass(frozen=True)
class Estimate:
    """MMSE estimate (eq. 2), the belief's weighted covariance and spread = trace (Table 4)."""

    mean: np.ndarray
    cov: np.ndarray
    spread: float
    size: int
    block_spread: float = float('nan')  # plain mean of ‖x̂ − x̂_MMSE‖² over the stored cells (Table 4's other reading)


def sparsify(grid: GridSpec, idx: np.ndarray, mass: np.ndarray,
             threshold: float = SPARSITY_THRESHOLD) -> SparseBelief:
    """Drop cells below ``threshold`` × max mass and renormalise (§2.3). Raises if no mass is left."""
    if not 0.0 <= threshold < 1.0:
        raise ValueError(f'threshold={threshold} must be in [0, 1)')
    idx = np.asarray(idx, dtype=np.int64)
    mass = np.asarray(mass, dtype=float)
    peak = mass.max(initial=0.0)
    if not (np.isfinite(peak) and peak > 0.0):
        raise ValueError(f'belief has no positive finite mass (max={peak})')
    keep = mass >= threshold * peak
    idx, mass = idx[keep], mass[keep]
    order = np.argsort(idx, kind='stable')
    idx, mass = idx[order], mass[order]
    return SparseBelief(grid, idx, mass / mass.sum())


def uniform_belief(grid: GridSpec) -> SparseBelief:
    """Uniform belief over the whole field (§5.1 start)."""
    n = grid.n_cells
    return SparseBelief(grid, np.arange(n, dtype=np.int64), np.full(n, 1.0 / n))


def from_dense(grid: GridSpec, dense: np.ndarray, threshold: float = SPARSITY_THRESHOLD) -> SparseBelief:
    """Sparse belief from a (ny, nx) array of non-negative masses."""
    flat = np.asarray(dense, dtype=float).reshape(-1)
    if flat.size != grid.n_cells:
        raise ValueError(f'dense size={flat.size} must equal grid cells={grid.n_cells}')
    nz = np.flatnonzero(flat > 0)
    return sparsify(grid, nz, flat[nz], threshold)


def estimate(belief: SparseBelief) -> Estimate:
    """MMSE centroid (eq. 2) and weighted covariance of the cell centres; spread = its trace."""
    xy = belief.centers()
    mean, cov = weighted_mean_cov(xy, belief.mass)
    blocks = float(np.mean(np.sum((xy - mean) ** 2, axis=1))) if belief.size else float('nan')
    return Estimate(mean, cov, float(np.trace(cov)), belief.size, blocks)


@lru_cache(maxsize=32)
def disk_kernel(radius: float, cell: float, supersample: int = 16) -> np.ndarray:
    """(2m+1, 2m+1) kernel: fraction of each cell's area inside a disk of ``radius`` (sum 1)."""
    if not (np.isfinite(radius) and radius >= 0):
        raise ValueError(f'radius={radius} must be a finite distance >= 0 m')
    m = max(int(np.ceil(radius / cell - 0.5 - 1e-9)), 0)
    off = np.arange(-m, m + 1) * cell
    sub = (np.arange(supersample) + 0.5) / supersample * cell - cell / 2
    px = off[:, None] + sub[None, :]                     # (2m+1, s) sample x within each column
    inside = (px[:, None, :, None] ** 2 + px[None, :, None, :] ** 2) <= radius ** 2
    k = inside.mean(axis=(2, 3))
    if k.sum() == 0.0:  # radius smaller than the supersampling: a delta
        k[m, m] = 1.0
    k.setflags(write=False)
    return k / k.sum()


def diffuse(belief: SparseBelief, radius: float, threshold: float = SPARSITY_THRESHOLD) -> SparseBelief:
    """Predicted belief p(x⁽ᵗ⁺¹⁾|z̄⁽ᵗ⁾): convolution with the uniform disk (§2.1, eq. 3 integral).

    Done on the support's bounding box padded by the kernel half-width (``fftconvolve``),
    cropped to the field, then re-sparsified and renormalised (mass 1).
    """
    return convolve(belief, disk_kernel(float(radius), belief.grid.cell), threshold)


def convolve(belief: SparseBelief, k: np.ndarray, threshold: float = SPARSITY_THRESHOLD) -> SparseBelief:
    """Belief convolved with a (2m+1, 2m+1) kernel ``k`` (rows = y, centre = zero displacement), cropped to
    the field, re-sparsified (``diffuse`` with any kernel, e.g. ``prediction.shifted_disk_kernel``)."""
    g = belief.grid
    m = k.shape[0] // 2
    iy, ix = np.divmod(belief.idx, g.nx)
    y_lo, x_lo = iy.min(), ix.min()
    box = np.zeros((iy.max() - y_lo + 1, ix.max() - x_lo + 1))
    box[iy - y_lo, ix - x_lo] = belief.mass
    conv = np.clip(fftconvolve(box, k, mode='full'), 0.0, None) if m > 0 else box
    # conv[0, 0] is at cell (y_lo − m, x_lo − m); crop to the field.
    yy = np.arange(conv.shape[0]) + y_lo - m
    xx = np.arange(conv.shape[1]) + x_lo - m
    oky = (yy >= 0) & (yy < g.ny)
    okx = (xx >= 0) & (xx < g.nx)
    conv = conv[np.ix_(oky, okx)]
    yy, xx = yy[oky], xx[okx]
    flat = (yy[:, None] * g.nx + xx[None, :]).reshape(-1)
    vals = conv.reshape(-1)
    nz = vals > 0
    return sparsify(g, flat[nz], vals[nz], threshold)
