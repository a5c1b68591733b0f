"""Point landmarks (tree trunks, poles, posts) from one planar laser scan.

The hybrid SLAM maps point landmarks observed in range and bearing (eq. 5); Victoria Park's trunks
came pre-extracted, so a robot with a plain ``sensor_msgs/LaserScan`` needs this front end (the
usual trunk detector of that data set's authors). Steps (``extract``, vectorised over beams and
segments):
1. Beams with a finite range in [range_min, range_max] (the scan's limits and ``max_range``).
2. Segments: consecutive valid beams whose ranges differ by at most ``jump`` + ``jump_ratio``·r.
3. Candidates: ``min_points`` ≤ n ≤ ``max_points``; width = chord of the end points + r·Δθ.
4. Round: a Kåsa circle fit x² + y² + Dx + Ey + F = 0 (one batched 3×3 least-squares solve) with
   diameter ≤ ``max_fit_diameter``, RMS residual ≤ ``max_residual`` and the centre behind the
   points (convex towards the laser: walls and concave corners refused).
5. Detection: diameter d = the width, range = the nearest beam's range + d/2 (the axis, as
   ``victoria.load``'s ``add_radius``), bearing = the middle of the segment's angular extent; kept
   when ``min_diameter`` ≤ d ≤ ``max_diameter``.
6. It stands out: the beam beyond each end is a no-return (REP-117) or farther by a jump; a segment
   at the scan's first or last beam is refused.

Covariance of (range, bearing, diameter), from ``sigma_range`` and Δθ (a model, not fitted):
σ_d² = 2σ_range² + (r·Δθ)²/3; σ_r² = σ_range² + σ_d²/4, cov(r, d) = σ_d²/2;
σ_β² = Δθ²/12 + (σ_range/r)². Bearings are REP-103 in the laser frame (0 = ahead,
counter-clockwise); eq. 5's (0 = right) is this + π/2 (``to_eq5_bearing``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from track_core.filters import wrap_angle


@dataclass(frozen=True)
class ExtractorParams:
    """Segmentation and shape limits of ``extract`` (module docstring); defaults suit trunks and poles."""

    jump: float = 0.3               # absolute range jump that starts a new segment [m]
    jump_ratio: float = 0.05        # ... plus this fraction of the range [-]
    min_points: int = 3             # beams a landmark must cover [-]
    max_points: int = 200           # beams beyond which a segment is a wall, not a landmark [-]
    min_diameter: float = 0.05      # [m]
    max_diameter: float = 1.5       # [m] (Victoria Park trunks: up to 1.5 m)
    max_fit_diameter: float = 3.0   # a fitted circle larger than this is a straight piece of wall [m]
    max_residual: float = 0.05      # RMS distance of the points to the fitted circle [m]
    max_range: float = 80.0         # beams beyond this are ignored [m]
    sigma_range: float = 0.03       # the laser's range noise (σ) [m]

    def __post_init__(self) -> None:
        for name in ('jump', 'max_diameter', 'max_fit_diameter', 'max_residual', 'max_range', 'sigma_range'):
            if not getattr(self, name) > 0:
                raise ValueError(f'{name} = {getattr(self, name)}: must be > 0')
        if self.jump_ratio < 0 or self.min_diameter < 0:
            raise ValueError('jump_ratio and min_diameter must be >= 0')
        if not 3 <= self.min_points <= self.max_points:
            raise ValueError(f'min_points = {self.min_points}, max_points = {self.max_points}: need 3 <= min <= max')
        if self.min_diameter > self.max_diameter:
            raise ValueError(f'min_diameter = {self.min_diameter} > max_diameter = {self.max_diameter}')


@dataclass(frozen=True)
class Detections:
    """Point landmarks of one scan: range to the centre [m], REP-103 bearing [rad], diameter [m],
    covariance of (range, bearing, diameter) (n, 3, 3)."""

    range: np.ndarray
    bearing: np.ndarray
    diameter: np.ndarray
    covariance: np.ndarray

    def __len__(self) -> int:
        return int(self.range.size)

    def eq5(self) -> np.ndarray:
        """(n, 2) of (range, bearing in eq. 5's convention) for ``HybridSlam.process_scan``."""
        return np.stack([self.range, to_eq5_bearing(self.bearing)], axis=1)


def to_eq5_bearing(bearing_rep103: np.ndarray) -> np.ndarray:
    """REP-103 bearing (0 = ahead) → eq. 5's (0 = right, π/2 ahead), wrapped to (−π, π].

    A value within 1e-9 rad above π is left unwrapped: π/2 + π/2 can round to an ulp above π, and a
    wrap would send a bearing of exactly "left" (π, the edge of a 180° laser's field) to −π, the other
    end; the caller's tolerance (``streams.scan_observations``) clips it back to π."""
    b = np.asarray(bearing_rep103, dtype=float) + np.pi / 2
    with np.errstate(invalid='ignore'):
        return np.where((b > np.pi) & (b <= np.pi + 1e-9), b, wrap_angle(b))


def empty() -> Detections:
    z = np.zeros(0)
    return Detections(z, z.copy(), z.copy(), np.zeros((0, 3, 3)))


def _stands_out(r: np.ndarray, idx: np.ndarray, starts: np.ndarray, ends: np.ndarray, rv: np.ndarray,
                range_max: float, p: ExtractorParams) -> np.ndarray:
    """Per segment: the beam just outside each end shows background, i.e. +inf or beyond the range limit
    (no return: REP-117) or a range farther than the segment's edge by a jump. A neighbour at about
    the same range (a wall cut by a dropout), NaN, −inf or too close (unknown) keeps it from counting."""
    far = min(range_max, p.max_range)
    out = np.ones(starts.size, bool)
    for nb, edge in ((idx[starts] - 1, rv[starts]), (idx[ends] + 1, rv[ends])):
        inside = (nb >= 0) & (nb < r.size)
        rn = r[np.clip(nb, 0, r.size - 1)]
        with np.errstate(invalid='ignore'):
            bg = (rn == np.inf) | (rn > far) | (rn > edge + p.jump + p.jump_ratio * edge)
        out &= inside & bg
    return out


def extract(ranges: np.ndarray, angle_min: float, angle_increment: float, range_min: float, range_max: float,
            params: ExtractorParams = ExtractorParams()) -> Detections:
    """Point landmarks of one scan (``sensor_msgs/LaserScan`` fields; module docstring)."""
    p = params
    r = np.asarray(ranges, dtype=float).ravel()
    inc = float(angle_increment)
    with np.errstate(invalid='ignore'):
        ok = np.isfinite(r) & (r >= max(range_min, 1e-6)) & (r <= min(range_max, p.max_range))
    idx = np.flatnonzero(ok)
    if idx.size < p.min_points or inc == 0.0:
        return empty()
    rv = r[idx]
    th = angle_min + inc * idx
    x, y = rv * np.cos(th), rv * np.sin(th)
    brk = (np.diff(idx) > 1) | (np.abs(np.diff(rv)) > p.jump + p.jump_ratio * np.minimum(rv[1:], rv[:-1]))
    starts = np.concatenate([[0], np.flatnonzero(brk) + 1])
    n = np.diff(np.concatenate([starts, [idx.size]]))
    ends = starts + n - 1

    def seg_sum(v: np.ndarray) -> np.ndarray:
        return np.add.reduceat(v, starts)

    seg = np.repeat(np.arange(starts.size), n)
    mx, my = seg_sum(x) / n, seg_sum(y) / n           # fit about each segment's mean point (conditioning)
    u, w = x - mx[seg], y - my[seg]
    z = u * u + w * w
    sx, sy, sz = seg_sum(u), seg_sum(w), seg_sum(z)
    A = np.empty((starts.size, 3, 3))
    A[:, 0, 0], A[:, 0, 1], A[:, 0, 2] = seg_sum(u * u), seg_sum(u * w), sx
    A[:, 1, 1], A[:, 1, 2], A[:, 2, 2] = seg_sum(w * w), sy, n
    A[:, 1, 0], A[:, 2, 0], A[:, 2, 1] = A[:, 0, 1], sx, sy
    rhs = -np.stack([seg_sum(u * z), seg_sum(w * z), sz], axis=1)
    cand = (n >= p.min_points) & (n <= p.max_points)
    # ill-conditioned (collinear points: a wall) → no circle; regularise so the batched solve never fails
    cond_ok = np.linalg.cond(A) < 1e12
    sol = np.linalg.solve(A + (~cond_ok)[:, None, None] * np.eye(3), rhs[..., None])[..., 0]
    ux, uy = -0.5 * sol[:, 0], -0.5 * sol[:, 1]       # centre about the mean point
    with np.errstate(invalid='ignore'):
        rad = np.sqrt(np.maximum(ux * ux + uy * uy - sol[:, 2], 0.0))
        cx, cy = ux + mx, uy + my
        dist = np.hypot(x - cx[seg], y - cy[seg]) - rad[seg]
        rms = np.sqrt(seg_sum(dist * dist) / n)
        mean_r = seg_sum(rv) / n
        round_ = (cond_ok & (2 * rad <= p.max_fit_diameter) & (rms <= p.max_residual)
                  & (np.hypot(cx, cy) > mean_r))
    r_near = np.minimum.reduceat(rv, starts)
    width = np.hypot(x[ends] - x[starts], y[ends] - y[starts]) + mean_r * abs(inc)
    keep = cand & round_ & (width >= p.min_diameter) & (width <= p.max_diameter) & _stands_out(r, idx, starts, ends,
                                                                                                 rv, range_max, p)
    if not keep.any():
        return empty()
    d, rn, mr = width[keep], r_near[keep], mean_r[keep]
    bearing = wrap_angle(angle_min + inc * 0.5 * (idx[starts[keep]] + idx[ends[keep]]))
    var_d = 2 * p.sigma_range**2 + (mr * inc) ** 2 / 3
    cov = np.zeros((d.size, 3, 3))
    cov[:, 0, 0] = p.sigma_range**2 + var_d / 4
    cov[:, 1, 1] = inc**2 / 12 + (p.sigma_range / mr) ** 2
    cov[:, 2, 2] = var_d
    cov[:, 0, 2] = cov[:, 2, 0] = var_d / 2
    return Detections(rn + d / 2, bearing, d, cov)
