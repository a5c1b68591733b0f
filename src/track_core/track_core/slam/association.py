"""Individual-compatibility nearest-neighbour association, ambiguity test and failure detector.

Vectorised over (observation × landmark) pairs; no Python loop over landmarks.

- Range: observations farther than ``max_range`` are ignored (neither associated nor mapped), so
  the failure detector, which watches the landmarks predicted within ``max_range``, watches every
  landmark association may use (Victoria Park's laser reports trunks up to 75 m).
- Gate: a pair (i, j) is compatible when νᵢⱼᵀ Sⱼ⁻¹ νᵢⱼ < ``gate`` (χ²₂, default 99 %: 9.21).
  ``Sⱼ = Hⱼ P Hⱼᵀ + R`` is the innovation covariance of landmark j (it does not depend on the
  observation, so it is computed once per landmark).
- Nearest neighbour: each observation takes its compatible landmark of smallest distance; when
  two observations claim one landmark, the closer one keeps it, the other is dropped.
- New landmark: an observation whose smallest distance exceeds ``new_gate`` (default χ²₂ at
  99.99 %: 18.42) and whose range is below ``init_max_range``; observations between the gates
  are discarded (neither trusted nor mapped).
- Ambiguity: an observation with more than one candidate inside the gate.
- Failure detector (§3.1, "monitoring the estimated error in vehicle and local map states"):
  the paper gives no formula; our documented rule compares the state-driven part of the
  innovation covariance of every landmark predicted in view, ``Sⱼ − R`` turned into metres by
  ``D = diag(1, r̂ⱼ)``, with the distance ``dⱼ`` to its nearest other landmark. Landmark j is
  *at risk* when ``n_sigma · √λmax(D (Sⱼ − R) D) > sep_fraction · dⱼ`` and ``dⱼ ≥
  min_separation`` (pairs closer than that are treated as one feature/clutter; they are not
  *eligible*). With n_sigma = 3 and sep_fraction = 0.5 the 3σ regions of neighbouring landmarks
  start to overlap, so nearest neighbour can no longer be trusted (Fig. 1: 10 m error, 8 m
  separation). The detector fires when at least one landmark is at risk and at least
  ``risk_fraction`` of the eligible in-view landmarks are (0 = any single one, the default).
  A fraction > 0 keeps one tight cluster of trunks from firing the detector while the vehicle is
  well localised; a loop closure with a large vehicle error puts nearly all of them at risk.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from track_core.filters import wrap_angle


@dataclass
class Association:
    """Outcome of one scan's association (indices into the scan / the candidate landmarks)."""

    obs: np.ndarray          # observation indices that were associated
    lm: np.ndarray           # their landmark indices (into the candidate list)
    new: np.ndarray          # observation indices that start new landmarks
    n_candidates: np.ndarray  # per observation, landmarks inside the gate
    d2: np.ndarray           # (n_obs, n_lm) Mahalanobis distances
    ambiguous: bool          # some observation has > 1 candidate (with distinct landmarks)
    risk: bool               # failure detector fired


def innovation_covariances(Hv: np.ndarray, Hm: np.ndarray, Pvv: np.ndarray, Pvm: np.ndarray,
                           Pmm: np.ndarray) -> np.ndarray:
    """State part of Sⱼ: Hv Pvv Hvᵀ + Hv Pvm Hmᵀ + (·)ᵀ + Hm Pmm Hmᵀ over landmarks j (M, 2, 2)."""
    cross = Hv @ Pvm @ np.swapaxes(Hm, -1, -2)
    S = Hv @ Pvv @ np.swapaxes(Hv, -1, -2) + cross + np.swapaxes(cross, -1, -2)
    return S + Hm @ Pmm @ np.swapaxes(Hm, -1, -2)


def associate(z: np.ndarray, zhat: np.ndarray, S_state: np.ndarray, R: np.ndarray, lm_xy: np.ndarray,
              *, gate: float = 9.21, new_gate: float = 18.42, init_max_range: float = np.inf,
              max_range: float = np.inf, n_sigma: float = 3.0, sep_fraction: float = 0.5,
              min_separation: float = 1.5, risk_fraction: float = 0.0) -> Association:
    """Associate observations ``z`` (n, 2) with predicted ``zhat`` (M, 2), see module docstring."""
    z = np.asarray(z, dtype=float).reshape(-1, 2)
    n, M = z.shape[0], zhat.shape[0]
    usable = z[:, 0] <= max_range
    if M == 0:
        new = np.flatnonzero((z[:, 0] < init_max_range) & usable)
        e = np.zeros(0, dtype=int)
        return Association(e, e, new, np.zeros(n, int), np.zeros((n, 0)), False, False)
    S = S_state + R
    nu = z[:, None, :] - zhat[None, :, :]
    nu[..., 1] = wrap_angle(nu[..., 1])
    s00, s01, s11 = S[:, 0, 0], 0.5 * (S[:, 0, 1] + S[:, 1, 0]), S[:, 1, 1]
    det = s00 * s11 - s01 * s01
    d2 = (s11 * nu[..., 0] ** 2 - 2.0 * s01 * nu[..., 0] * nu[..., 1] + s00 * nu[..., 1] ** 2) / det
    d2[~usable] = np.inf
    inside = d2 < gate
    n_cand = inside.sum(axis=1)
    best = np.argmin(d2, axis=1)
    dmin = d2[np.arange(n), best]
    ok = dmin < gate
    # one landmark per observation: keep the closest claimant
    order = np.argsort(dmin, kind='stable')
    order = order[ok[order]]
    _, first = np.unique(best[order], return_index=True)
    keep = np.sort(order[first])
    new = np.flatnonzero((dmin > new_gate) & (z[:, 0] < init_max_range) & usable)
    # landmark separations (to the nearest other landmark), only for those predicted in view
    view = np.flatnonzero(zhat[:, 0] <= max_range)
    ambiguous = False
    risk = False
    if M > 1:
        dist = np.linalg.norm(lm_xy[view, None, :] - lm_xy[None, :, :], axis=-1)
        dist[np.arange(view.size), view] = np.inf
        dnn = dist.min(axis=1) if view.size else np.zeros(0)
        D = np.ones((view.size, 2))
        D[:, 1] = zhat[view, 0]
        Sm = S_state[view] * D[:, :, None] * D[:, None, :]
        a, b, c = Sm[:, 0, 0], 0.5 * (Sm[:, 0, 1] + Sm[:, 1, 0]), Sm[:, 1, 1]
        lmax = 0.5 * (a + c) + np.sqrt(0.25 * (a - c) ** 2 + b * b)      # λmax of a 2×2 symmetric
        sig = np.sqrt(np.maximum(lmax, 0.0))
        eligible = dnn >= min_separation
        at_risk = (n_sigma * sig > sep_fraction * dnn) & eligible
        n_risk = int(at_risk.sum())
        risk = n_risk > 0 and n_risk >= risk_fraction * int(eligible.sum())
        multi = np.flatnonzero(n_cand > 1)
        if multi.size:
            # distinct landmarks: candidates farther apart than min_separation
            cand_xy = np.where(inside[multi][..., None], lm_xy[None], np.nan)
            spread = np.nanmax(cand_xy, axis=1) - np.nanmin(cand_xy, axis=1)
            ambiguous = bool(np.any(np.hypot(spread[:, 0], spread[:, 1]) >= min_separation))
    return Association(keep, best[keep], new, n_cand, d2, ambiguous, risk)
