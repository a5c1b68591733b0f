"""Angle helpers: wrapping to (−π, π], the (weighted) circular mean, and the inverse of a planar pose."""

from __future__ import annotations

import numpy as np


def wrap_angle(a: np.ndarray | float) -> np.ndarray:
    """Wrap angles (rad) to the half-open interval (−π, π]; +π stays +π, −π maps to +π."""
    a = np.asarray(a, dtype=float)
    return np.pi - np.mod(np.pi - a, 2.0 * np.pi)


def circular_mean(a: np.ndarray, weights: np.ndarray | None = None, axis: int = -1) -> np.ndarray:
    """Mean direction atan2(Σ wᵢ sin aᵢ, Σ wᵢ cos aᵢ) along ``axis``, in (−π, π].

    Weights need not be normalised; they must be non-negative for the result to be a mean.
    """
    a = np.asarray(a, dtype=float)
    w = np.ones_like(a) if weights is None else np.broadcast_to(np.asarray(weights, dtype=float), a.shape)
    s = np.sum(w * np.sin(a), axis=axis)
    c = np.sum(w * np.cos(a), axis=axis)
    return wrap_angle(np.arctan2(s, c))


def invert_pose(pose: np.ndarray) -> np.ndarray:
    """The inverse of planar poses ``(..., 3)`` = (x, y, θ) of frame B in frame A: the pose of A in B.

    (x', y') = −R(−θ)·(x, y), θ' = −θ (wrapped), so composing a pose with its inverse gives the identity.
    """
    pose = np.asarray(pose, dtype=float)
    x, y, th = pose[..., 0], pose[..., 1], pose[..., 2]
    c, s = np.cos(th), np.sin(th)
    return np.stack([-(c * x + s * y), s * x - c * y, wrap_angle(-th)], axis=-1)
