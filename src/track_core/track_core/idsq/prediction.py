"""Prediction step of the grid belief: the paper's diffusion (§2.1) or a velocity-aware one (beyond the paper).

``TrackerParams.prediction`` selects it; the Table 4/5 reproduction uses the default.

- ``'diffusion'`` (default, the paper's): p(x⁽ᵗ⁺¹⁾|x⁽ᵗ⁾) is the uniform disk of radius v_max·Δt
  centred on x⁽ᵗ⁾ (``grid.diffuse``); no drift, so the MMSE mean lags a moving vehicle.
- ``'drift'``: the disk, radius ``drift_speed``·Δt, centred on x⁽ᵗ⁾ + v̂·Δt
  (``shifted_disk_kernel``, 1/16-cell supersampling), with v̂⁽ᵗ⁾ = v̂⁽ᵗ⁻¹⁾ + β((x̂⁽ᵗ⁾ − x̂⁽ᵗ⁻¹⁾)/Δt
  − v̂⁽ᵗ⁻¹⁾), β = ``drift_gain`` (0.3), the first observation taken whole, |v̂| ≤ v_max, used only
  when both posteriors' spread is below ``drift_gate``·(v_max·Δt)² (``Motion``); the paper's disk
  until then. Handoff version 2, +10 bytes.
- ``'bank'``: velocity hypotheses on a square lattice of spacing ``bank_step`` (5 m/s) inside |v| ≤
  v_max (29 at 15 m/s), each with its own grid (``Bank``): a hypothesis moves to one of its 4
  neighbours with probability q, each grid is shifted by v_j·Δt and diffused by a disk of radius
  ``bank_step``/√2·Δt (one batched FFT convolution); the update multiplies every (j, cell) mass by
  p(z|cell); sparsified against the joint's peak; estimates, MI and ``SparseBelief`` use the
  position marginal. Handoff version 3: 6 + 8 bytes per stored (hypothesis, cell) entry.
- q is a rate: ``bank_switch`` (0.1) per ``bank_switch_dt`` (0.5 s), q = 1 − (1 − 0.1)^(Δt/0.5 s)
  (``TrackerParams.switch_per_step``). Which to use, and why: docs/MODULES.md, "The IDSQ prediction";
  the maritime scenario uses the bank.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from scipy.signal import fftconvolve

from track_core.idsq.grid import SparseBelief, convolve, disk_kernel, estimate
from track_core.idsq.motion import NO_MOTION, Bank, Motion

PREDICTIONS = ('diffusion', 'drift', 'bank')


def shifted_disk_kernel(radius: float, offset: np.ndarray, cell: float, supersample: int = 16) -> np.ndarray:
    """(2m+1, 2m+1) kernel, rows = y: area fraction of each cell inside the disk of ``radius`` centred at
    ``offset`` (x, y) [m] from the kernel's centre cell; sums to 1. ``offset = 0`` is ``disk_kernel``."""
    off = np.asarray(offset, dtype=float).reshape(2)
    if not (np.isfinite(radius) and radius >= 0 and np.all(np.isfinite(off))):
        raise ValueError(f'radius={radius}, offset={off} must be finite, radius >= 0 m')
    if not off.any():
        return disk_kernel(float(radius), cell, supersample)
    m = max(int(np.ceil((radius + np.abs(off).max()) / cell - 0.5 - 1e-9)), 0)
    c = np.arange(-m, m + 1) * cell
    sub = (np.arange(supersample) + 0.5) / supersample * cell - cell / 2
    px = (c[:, None] + sub[None, :]) - off[0]   # (2m+1, s) sample x relative to the disk centre
    py = (c[:, None] + sub[None, :]) - off[1]
    inside = (py[:, None, :, None] ** 2 + px[None, :, None, :] ** 2) <= radius ** 2
    k = inside.mean(axis=(2, 3))
    if k.sum() == 0.0:  # disk smaller than the supersampling: all mass in the cell holding the centre
        iy, ix = (np.clip(np.floor(off[::-1] / cell + 0.5).astype(int), -m, m) + m)
        k[iy, ix] = 1.0
    return k / k.sum()


def drift_radius(p) -> float:
    """Radius of the drift kernel: ``drift_speed``·Δt [m]."""
    return p.drift_speed * p.dt


def predict(belief: SparseBelief, p) -> SparseBelief:
    """p(x⁽ᵗ⁺¹⁾|z̄⁽ᵗ⁾) by ``p.prediction`` (module docstring); the result carries ``belief.motion``."""
    if p.prediction not in PREDICTIONS:
        raise ValueError(f'prediction={p.prediction!r} must be one of {PREDICTIONS}')
    if p.prediction == 'bank':
        return predict_bank(belief, p)
    mo = belief.motion
    if p.prediction == 'diffusion' or mo is None or mo.count == 0:
        k = disk_kernel(float(p.radius), belief.grid.cell)
    else:
        k = shifted_disk_kernel(drift_radius(p), mo.velocity * p.dt, belief.grid.cell)
    return convolve(belief, k, p.sparsity).with_motion(mo)


def update_motion(prior: SparseBelief, posterior: SparseBelief, p) -> Motion | None:
    """v̂ after one step (module docstring): ``prior`` is the handed-off posterior of t − 1, ``posterior``
    that of t. ``None`` under the paper's diffusion (nothing is carried)."""
    if p.prediction == 'bank':
        return posterior.motion
    if p.prediction != 'drift':
        return None
    mo = prior.motion if isinstance(prior.motion, Motion) else NO_MOTION
    a, b = estimate(prior), estimate(posterior)
    gate = p.drift_gate * p.radius ** 2
    if not (a.spread < gate and b.spread < gate):
        return mo
    obs = (b.mean - a.mean) / p.dt
    v = obs if mo.count == 0 else mo.velocity + p.drift_gain * (obs - mo.velocity)
    speed = float(np.hypot(*v))
    if speed > p.v_max:
        v = v * (p.v_max / speed)
    return Motion(v, min(mo.count + 1, 65535))


# --- velocity-hypothesis bank (a coarse joint position-velocity grid) -------------------------------------

@lru_cache(maxsize=8)
def bank_velocities(step: float, v_max: float) -> tuple[np.ndarray, np.ndarray]:
    """Square lattice of velocities (J, 2), spacing ``step`` m/s, |v| ≤ v_max, and its (J, J) 4-neighbour
    adjacency (the hypotheses a velocity can switch to in one step)."""
    n = int(np.floor(v_max / step + 1e-9))
    a = np.arange(-n, n + 1)
    ij = np.stack(np.meshgrid(a, a, indexing='ij'), axis=-1).reshape(-1, 2)
    ij = ij[np.hypot(*ij.T) * step <= v_max + 1e-9]
    adj = (np.abs(ij[:, None, :] - ij[None, :, :]).sum(axis=-1) == 1).astype(float)
    v = ij * float(step)
    v.setflags(write=False)
    adj.setflags(write=False)
    return v, adj


def _marginal(grid, bank: Bank) -> SparseBelief:
    cell = bank.key % grid.n_cells
    idx, inv = np.unique(cell, return_inverse=True)
    m = np.bincount(inv, weights=bank.mass, minlength=idx.size)
    return SparseBelief(grid, idx, m / m.sum(), bank)


def bank_from_joint(grid, step: float, n_hyp: int, key: np.ndarray, mass: np.ndarray,
                    threshold: float) -> SparseBelief:
    """Marginal belief carrying the joint ``(key, mass)``, sparsified jointly (relative to the joint peak)."""
    peak = mass.max(initial=0.0)
    if not (np.isfinite(peak) and peak > 0.0):
        raise ValueError(f'joint belief has no positive finite mass (max={peak})')
    keep = mass >= threshold * peak
    key, mass = key[keep], mass[keep]
    order = np.argsort(key, kind='stable')
    return _marginal(grid, Bank(float(step), int(n_hyp), key[order], mass[order] / mass[order].sum()))


def predict_bank(belief: SparseBelief, p) -> SparseBelief:
    """Bank prediction: switch to a 4-neighbour hypothesis with probability ``switch_per_step``, then shift each
    hypothesis' grid by v_j·Δt while diffusing it by a disk of radius ``bank_step``/√2·Δt (the lattice
    cell's half-diagonal), all hypotheses in one batched FFT convolution; joint sparsification."""
    g = belief.grid
    vel, adj = bank_velocities(float(p.bank_step), float(p.v_max))
    J = vel.shape[0]
    bank = belief.motion if isinstance(belief.motion, Bank) and belief.motion.n_hyp == J else None
    if bank is None:  # no velocity known yet (uniform start): every hypothesis equally likely
        key = (np.arange(J)[:, None] * g.n_cells + belief.idx[None, :]).reshape(-1)
        bank = Bank(float(p.bank_step), J, key, np.tile(belief.mass / J, J))
    hyp, cell = np.divmod(bank.key, g.n_cells)
    cells, inv = np.unique(cell, return_inverse=True)
    dense = np.zeros((J, cells.size))
    dense[hyp, inv] = bank.mass
    deg = adj.sum(axis=1, keepdims=True)
    q = p.switch_per_step  # bank_switch is a rate (per bank_switch_dt), module docstring
    dense = (1.0 - q) * dense + q * (adj / deg).T @ dense      # switching
    r = p.bank_step / np.sqrt(2.0) * p.dt
    ks = [shifted_disk_kernel(r, v * p.dt, g.cell) for v in vel]
    m = max(k.shape[0] for k in ks) // 2
    kern = np.zeros((J, 2 * m + 1, 2 * m + 1))
    for j, k in enumerate(ks):  # J kernels (not cells): centre each in the common size
        q = m - k.shape[0] // 2
        kern[j, q:q + k.shape[0], q:q + k.shape[0]] = k
    iy, ix = np.divmod(cells, g.nx)
    y_lo, x_lo = iy.min(), ix.min()
    box = np.zeros((J, iy.max() - y_lo + 1, ix.max() - x_lo + 1))
    box[:, iy - y_lo, ix - x_lo] = dense
    conv = np.clip(fftconvolve(box, kern, mode='full', axes=(1, 2)), 0.0, None)
    yy = np.arange(conv.shape[1]) + y_lo - m
    xx = np.arange(conv.shape[2]) + x_lo - m
    oky, okx = (yy >= 0) & (yy < g.ny), (xx >= 0) & (xx < g.nx)
    conv = conv[:, oky][:, :, okx]
    flat = (yy[oky][:, None] * g.nx + xx[okx][None, :]).reshape(-1)
    key = (np.arange(J)[:, None] * g.n_cells + flat[None, :]).reshape(-1)
    vals = conv.reshape(-1)
    nz = vals > 0
    return bank_from_joint(g, p.bank_step, J, key[nz], vals[nz], p.sparsity)


def reweight_bank(belief: SparseBelief, lik: np.ndarray, threshold: float) -> SparseBelief:
    """Update of the joint belief: every hypothesis' cell mass × p(z|cell) (``lik`` over ``belief.idx``)."""
    bank = belief.motion
    pos = np.searchsorted(belief.idx, bank.key % belief.grid.n_cells)
    return bank_from_joint(belief.grid, bank.step, bank.n_hyp, bank.key, bank.mass * lik[pos], threshold)



def bank_velocity(belief: SparseBelief, v_max: float) -> np.ndarray:
    """Posterior-mean velocity Σ_j P(j)·v_j of a bank belief [m/s]."""
    b = belief.motion
    vel, _ = bank_velocities(b.step, float(v_max))
    w = np.bincount(b.key // belief.grid.n_cells, weights=b.mass, minlength=b.n_hyp)
    return w @ vel
