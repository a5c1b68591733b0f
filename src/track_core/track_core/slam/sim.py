"""Seeded loop-closure world of Fig. 1 (the paper's §6).

A rectangular loop (``width`` × ``height`` m) driven anticlockwise (east, north, west, south)
from a start area densely populated with landmarks on a jittered 8 m grid (the paper's A and B, 8 m
apart); the far legs carry only a few landmarks, so the dead-reckoned error grows to about ten
metres when the vehicle comes back (measured: see the slam-loop experiment). After returning the
vehicle drives on through the start area. The truth (the "GPS") is for evaluation only.

The vehicle follows the waypoints with a proportional steering law on the true pose; the filter
receives the true inputs plus white noise (σ_v, σ_α) — the same ACFR model as the filter.
The sensor sees landmarks within ``max_range`` and bearing [0, π] (eq. 5; the front half-plane)
with Gaussian range/bearing noise.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from track_core.filters import wrap_angle
from track_core.slam.models import VehicleParams, observe, vehicle_step


@dataclass(frozen=True)
class LoopWorld:
    width: float = 200.0
    height: float = 150.0
    speed: float = 4.0
    dt: float = 0.1
    scan_every: int = 2
    spacing: float = 8.0
    sparse_every: float = 60.0
    sigma_v: float = 0.2
    sigma_steer: float = np.deg2rad(0.6)
    sigma_r: float = 0.2
    sigma_b: float = np.deg2rad(0.5)
    max_range: float = 30.0
    jitter: float = 2.5           # uniform jitter of the dense grid [m] (fixed layout)
    layout_seed: int = 7
    run_on: float = 50.0          # metres driven past the start after closing the loop
    vehicle: VehicleParams = field(default_factory=VehicleParams)

    def landmarks(self) -> np.ndarray:
        """Jittered 8 m grid along the start of the first leg (rows y = ±8, ±16) + a few sparse ones."""
        xs = np.arange(-24.0, 48.0 + 1e-9, self.spacing)
        ys = np.array([-16.0, -8.0, 8.0, 16.0])
        dense = np.stack(np.meshgrid(xs, ys), -1).reshape(-1, 2)
        # sparse: along the first leg (east) only, offset 10 m; the rest 1-2-3 has none but one
        sx = np.arange(80.0, self.width - 20.0 + 1e-9, self.sparse_every)
        sparse = np.concatenate([np.stack([sx, np.full_like(sx, 10.0)], 1),
                                 [[self.width + 10.0, self.height / 2]]])
        # natural features are irregular: a perfectly periodic grid would make every 8 m shift of the
        # vehicle explain a scan equally well, for any association-free localiser
        jit = np.random.default_rng(self.layout_seed).uniform(-self.jitter, self.jitter, dense.shape)
        return np.concatenate([dense + jit, sparse])

    def start(self) -> np.ndarray:
        """Start pose: west of the landmark area, heading east, so the whole area is mapped first."""
        return np.array([-40.0, 0.0, 0.0])

    def waypoints(self) -> np.ndarray:
        w, h = self.width, self.height
        return np.array([[w, 0.0], [w, h], [0.0, h], [0.0, 0.0], [self.run_on, 0.0]])


@dataclass
class SimRun:
    t: np.ndarray          # input times (K,)
    truth: np.ndarray      # (K + 1, 3) true poses (index 0 = start)
    u_meas: np.ndarray     # (K, 2) noisy inputs applied from t[k] to t[k] + dt
    scans: list            # [(t, z (n, 2), landmark ids (n,))]
    landmarks: np.ndarray


def simulate(world: LoopWorld, rng: np.random.Generator) -> SimRun:
    """Drive the loop once; returns truth, noisy inputs and scans (scan at t = (k+1)·dt after step k)."""
    lm = world.landmarks()
    wps = world.waypoints()
    pose = world.start()
    poses, us, ts, scans = [pose.copy()], [], [], []
    wi, k = 0, 0
    while wi < len(wps) and k < 100000:
        tgt = wps[wi]
        if np.linalg.norm(tgt - pose[:2]) < 6.0:
            wi += 1
            continue
        eta = wrap_angle(np.arctan2(tgt[1] - pose[1], tgt[0] - pose[0]) - pose[2])
        u = np.array([world.speed, float(np.clip(1.2 * eta, -0.45, 0.45))])
        us.append(u + rng.standard_normal(2) * [world.sigma_v, world.sigma_steer])
        ts.append(k * world.dt)
        pose = vehicle_step(pose, u, world.dt, world.vehicle)
        poses.append(pose.copy())
        k += 1
        if k % world.scan_every == 0:
            zz = observe(pose, lm)
            vis = np.flatnonzero((zz[:, 0] <= world.max_range) & (zz[:, 1] >= 0) & (zz[:, 1] <= np.pi))
            z = zz[vis] + rng.standard_normal((vis.size, 2)) * [world.sigma_r, world.sigma_b]
            z[:, 1] = np.clip(z[:, 1], 0.0, np.pi)
            scans.append((k * world.dt, z, vis))
    return SimRun(np.array(ts), np.array(poses), np.array(us), scans, lm)


def raycast_scan(pose: np.ndarray, angles: np.ndarray, walls: np.ndarray, poles: np.ndarray, radii: np.ndarray,
                 max_range: float, sigma: float = 0.0, rng: np.random.Generator | None = None) -> np.ndarray:
    """Ranges a planar laser at ``pose`` (x, y, heading) measures along ``angles`` (REP-103, laser frame)
    in a world of wall segments ``walls`` (k, 2, 2) and round poles (centres (m, 2), ``radii`` (m,));
    ``inf`` where nothing is within ``max_range``; Gaussian noise σ = ``sigma`` with ``rng``.

    Vectorised over beams × objects: ray–segment and ray–circle intersections, nearest hit per beam.
    (A test world for the landmark extractor, ``landmarks.extract``.)
    """
    pose = np.asarray(pose, dtype=float)
    th = pose[2] + np.asarray(angles, dtype=float)
    d = np.stack([np.cos(th), np.sin(th)], axis=1)                 # (B, 2) beam directions
    o = pose[:2]
    best = np.full(th.size, np.inf)
    walls = np.asarray(walls, dtype=float).reshape(-1, 2, 2)
    if walls.size:
        a, e = walls[:, 0], walls[:, 1] - walls[:, 0]              # (k, 2)
        den = d[:, None, 0] * e[None, :, 1] - d[:, None, 1] * e[None, :, 0]   # cross(d, e)
        w = a - o
        with np.errstate(divide='ignore', invalid='ignore'):
            t = (w[None, :, 0] * e[None, :, 1] - w[None, :, 1] * e[None, :, 0]) / den
            u = (w[None, :, 0] * d[:, None, 1] - w[None, :, 1] * d[:, None, 0]) / den
        hit = np.isfinite(t) & (t > 0) & (u >= 0) & (u <= 1)
        best = np.minimum(best, np.where(hit, t, np.inf).min(axis=1))
    poles = np.asarray(poles, dtype=float).reshape(-1, 2)
    if poles.size:
        c = poles - o                                                 # (m, 2)
        proj = d @ c.T                                                # (B, m)
        disc = proj**2 - (np.sum(c * c, axis=1) - np.asarray(radii, dtype=float) ** 2)[None, :]
        with np.errstate(invalid='ignore'):
            t = proj - np.sqrt(disc)
        hit = (disc >= 0) & (t > 0)
        best = np.minimum(best, np.where(hit, t, np.inf).min(axis=1))
    if sigma > 0 and rng is not None:
        best = best + sigma * rng.standard_normal(best.size)
    best[best > max_range] = np.inf
    return best
