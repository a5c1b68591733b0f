"""One leader's step of the IDSQ tracker (Table 1) and the centralized baseline (§2.2, eq. 4).

``leader_step`` is what a sensor node runs when a handoff arrives: it takes the handed-off
belief, the leader's own measurement and the layout, and returns the posterior, the estimate,
the chosen next leader and the encoded handoff payload. It is pure (no state kept between
calls); the node keeps the step number and the previous leader (from the handoff).

Interpretations:
- Prediction (Table 1 step 1): ``p.prediction``, the paper's diffusion (default), ``drift`` or the
  hypothesis ``bank`` (``prediction.py``); the posterior carries its motion state, which the MI
  of step 4 and the handoff use; a bank update weights every (hypothesis, cell) mass by its cell's
  likelihood.
- Step 4 scores I(x⁽ᵗ⁺²⁾; z_k⁽ᵗ⁺²⁾|z̄⁽ᵗ⁺¹⁾): the posterior is diffused once more (Table 3 step 1)
  before each candidate's MI; the *posterior* is handed off and the receiver diffuses it.
- A measurement with zero likelihood on the whole support is skipped (prior kept, a warning).
- An amplitude above the grid's reach (a target within a cell of an acoustic leader, z = A/r
  large) is clipped to a_hi/r_min, r_min the range of the support's nearest cell; every z the grid
  can explain is unchanged.
- Candidates: the leader's neighbourhood after the triplet rule (``network.candidates``: within
  40 m or else the two nearest, the previous leader excluded); ``neighbourhood_size`` is Table 4's
  "avg. neigh. size".
- Baselines: ``selection='nearest'`` (the candidate nearest the predicted MMSE estimate),
  ``'random'`` (uniform, with the given Generator); centralized (§2.2): every sensor's measurement
  fused each step by the product of likelihoods (eq. 4) on the same sparse grid.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from track_core.idsq.grid import Estimate, SparseBelief, diffuse, estimate, sparsify
from track_core.idsq.handoff import Handoff, encode_handoff
from track_core.idsq.mi import DZ_PER_SIGMA, neighbour_mi
from track_core.idsq.models import TrackerParams, likelihood, ranges
from track_core.idsq.network import SensorLayout, candidates
from track_core.idsq.prediction import Bank, predict, reweight_bank, update_motion

log = logging.getLogger(__name__)

SELECTIONS = ('mi', 'nearest', 'random')


@dataclass(frozen=True)
class LeaderStepResult:
    """Output of one leader step: posterior, estimate, next leader and the handoff bytes."""

    belief: SparseBelief
    estimate: Estimate
    next_leader: int
    payload: bytes
    candidates: np.ndarray
    scores: np.ndarray
    neighbourhood_size: int  # |candidates| after the triplet rule (Table 4's "neigh. size")
    updated: bool


def update(belief: SparseBelief, z: float, sensor: np.ndarray, is_doa: bool,
           p: TrackerParams) -> tuple[SparseBelief, bool]:
    """Eq. 3 / Table 1 step 3: posterior ∝ p(z|x)·prior on the support, re-sparsified; (belief, applied)."""
    if not np.isfinite(z):
        raise ValueError(f'measurement z={z} must be finite')
    xy = belief.centers()
    if not is_doa and xy.size:  # amplitude above the grid's reach (module docstring)
        z = min(z, p.a_hi / max(float(ranges(xy, sensor).min()), 1e-9))
    lik = likelihood(z, xy, sensor, is_doa, p)
    post = belief.mass * lik
    if not (np.all(np.isfinite(post)) and post.max() > 0.0):
        log.warning('measurement z=%.4g has zero likelihood on the whole belief; update skipped', z)
        return belief, False
    if isinstance(belief.motion, Bank):  # joint position-velocity belief (prediction='bank')
        return reweight_bank(belief, lik, p.sparsity), True
    return sparsify(belief.grid, belief.idx, post, p.sparsity), True


def select_next(posterior: SparseBelief, layout: SensorLayout, leader: int, previous: int | None,
                p: TrackerParams, selection: str = 'mi', rng: np.random.Generator | None = None,
                dz_per_sigma: float = DZ_PER_SIGMA) -> tuple[int, np.ndarray, np.ndarray]:
    """Table 1 step 4 / eq. 15: (next leader, candidates, scores) among the leader's neighbours."""
    if selection not in SELECTIONS:
        raise ValueError(f'selection={selection!r} must be one of {SELECTIONS}')
    cands = candidates(layout, leader, previous)
    if selection == 'random':
        if rng is None:
            raise ValueError('rng=None: random selection needs a numpy Generator')
        scores = np.zeros(cands.size)
        return int(cands[rng.integers(cands.size)]), cands, scores
    pred = predict(posterior, p)
    if selection == 'nearest':
        centre = estimate(pred).mean
        scores = -np.linalg.norm(layout.positions[cands] - centre, axis=1)
    else:
        scores = neighbour_mi(pred, layout.positions, layout.is_doa, cands, p, dz_per_sigma)
    return int(cands[int(np.argmax(scores))]), cands, scores


def leader_step(belief: SparseBelief, z: float | None, leader: int, layout: SensorLayout, p: TrackerParams, *,
                step: int, previous: int | None = None, selection: str = 'mi',
                rng: np.random.Generator | None = None) -> LeaderStepResult:
    """Table 1 steps 1-5 for sensor ``leader`` holding the handed-off ``belief`` and its own ``z``.

    ``step`` is the time index of this measurement; the payload carries it to the next leader.
    ``z`` None: no reading came (a silent front end): the step is predict-only, the diffused belief
    is the posterior (eq. 3 without a likelihood), ``updated`` False, and the leader still picks
    and hands on (``leader_protocol``, missing readings).
    """
    if not 0 <= leader < layout.n:
        raise ValueError(f'leader={leader} must be in [0, {layout.n - 1}]')
    prior = predict(belief, p)                                                             # step 1
    if z is None:
        post, ok = prior, False
    else:
        post, ok = update(prior, z, layout.positions[leader], bool(layout.is_doa[leader]), p)  # steps 2-3
    post = post.with_motion(update_motion(belief, post, p))  # v̂ (prediction='drift' only)
    nxt, cands, scores = select_next(post, layout, leader, previous, p, selection, rng)    # step 4
    payload = encode_handoff(Handoff.from_belief(step, leader, nxt, post))            # step 5
    return LeaderStepResult(post, estimate(post), nxt, payload, cands, scores,
                            int(cands.size), ok)


def centralized_step(belief: SparseBelief, zs: np.ndarray, layout: SensorLayout,
                     p: TrackerParams) -> tuple[SparseBelief, Estimate]:
    """§2.2: diffuse, then fuse all K measurements ``zs`` (eq. 4, log-likelihoods summed per cell)."""
    zs = np.asarray(zs, dtype=float)
    if zs.shape != (layout.n,):
        raise ValueError(f'zs shape={zs.shape} must be ({layout.n},)')
    prior = diffuse(belief, p.radius, p.sparsity)
    xy = prior.centers()
    with np.errstate(divide='ignore'):
        logl = np.log(prior.mass)
        for k in range(layout.n):  # K sensors; each term vectorised over cells
            logl = logl + np.log(likelihood(zs[k], xy, layout.positions[k], bool(layout.is_doa[k]), p))
    if not np.isfinite(logl.max()):
        log.warning('centralized measurements have zero joint likelihood on the belief; update skipped')
        return prior, estimate(prior)
    post = sparsify(prior.grid, prior.idx, np.exp(logl - logl.max()), p.sparsity)
    return post, estimate(post)
