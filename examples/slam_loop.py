"""Hybrid CEKF / particle-filter SLAM on a few simulated landmarks (``track_core.slam``)
=====================================================================================

A car (the ACFR utility vehicle's geometry, the laser 3.78 m ahead of the rear axle) drives one and a
half laps of a 25 m circle among 25 point landmarks (tree trunks), at 4 m/s. Its encoder speed and
steering angle reach the filter with noise every 0.1 s; every 0.2 s its laser returns the range and
bearing (eq. 5: bearing 0 to the right, π/2 ahead) of each landmark in the front half-plane within
30 m. ``HybridSlam`` maps the landmarks with the Compressed EKF and hands over to particle-filter
localisation when the association of a scan cannot be trusted (§3.1), then back.

The script prints the final pose error against the filter's own covariance (the pose NEES: for a
consistent filter a χ² draw with 3 degrees of freedom), the landmarks it mapped, their RMS error,
and how many times it switched to the particle filter.

    python examples/slam_loop.py [--seed 1] [--out slam.png]
"""

import argparse
import math

import numpy as np

from track_core.slam import HybridSlam, SlamParams, VehicleParams

ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
ap.add_argument('--seed', type=int, default=1)
ap.add_argument('--out', help='write a figure of the map to this PNG file (needs matplotlib)')
args = ap.parse_args()
rng = np.random.default_rng(args.seed)

# %%
# The world: 25 landmarks at least 6 m apart, 8–45 m from the circle's centre (irregular, as trees are).
landmarks = []
while len(landmarks) < 25:
    p = rng.uniform(-45.0, 45.0, 2)
    if 8.0 < np.hypot(*p) < 45.0 and all(np.hypot(*(p - q)) > 6.0 for q in landmarks):
        landmarks.append(p)
landmarks = np.array(landmarks)
car = VehicleParams()


def drive(pose, speed, steer, dt):
    """The ACFR model (``track_core.slam.models``): one Euler step of the laser's pose (x, y, φ)."""
    vc = speed / (1.0 - math.tan(steer) * car.H / car.L)
    turn = vc / car.L * math.tan(steer)
    x, y, phi = pose
    return np.array([x + dt * (vc * math.cos(phi) - turn * (car.a * math.sin(phi) + car.b * math.cos(phi))),
                     y + dt * (vc * math.sin(phi) + turn * (car.a * math.cos(phi) - car.b * math.sin(phi))),
                     phi + dt * turn])


def scan(pose):
    """Eq. 5 with noise: (range, bearing) of the landmarks in the front half-plane within 30 m."""
    d = landmarks - pose[:2]
    z = np.stack([np.hypot(d[:, 0], d[:, 1]), np.arctan2(d[:, 1], d[:, 0]) - pose[2] + np.pi / 2], axis=1)
    z[:, 1] = (z[:, 1] + np.pi) % (2 * np.pi) - np.pi
    seen = (z[:, 0] <= 30.0) & (z[:, 1] >= 0.0) & (z[:, 1] <= np.pi)
    z = z[seen] + rng.standard_normal((seen.sum(), 2)) * [sigma_r, sigma_b]
    z[:, 1] = np.clip(z[:, 1], 0.0, np.pi)
    return z, seen


# %%
# The filter: its noise model is the simulation's (inputs 0.2 m/s and 0.6°, laser 0.2 m and 0.5°).
sigma_v, sigma_steer, sigma_r, sigma_b = 0.2, math.radians(0.6), 0.2, math.radians(0.5)
params = SlamParams(sigma_v=sigma_v, sigma_steer=sigma_steer, sigma_r=sigma_r, sigma_b=sigma_b)
pose = np.array([0.0, -25.0, 0.0])  # south of the centre, heading east: the circle is anticlockwise
slam = HybridSlam(pose, np.diag([0.01, 0.01, 1e-4]), np.random.default_rng(rng.integers(2**32)), params)

# %%
# The drive: inputs every 0.1 s (held until the next), a scan every second input.
dt, speed, steer = 0.1, 4.0, math.atan(car.L / 25.0)
seen_ever = np.zeros(len(landmarks), bool)
truth, track = [pose], [slam.pose]
for k in range(2 * int(1.5 * math.pi * 25.0 / speed / dt)):  # an even count: the last input ends at a scan
    slam.process_input(k * dt, speed + sigma_v * rng.standard_normal(), steer + sigma_steer * rng.standard_normal())
    pose = drive(pose, speed, steer, dt)
    if k % 2 == 1:
        z, seen = scan(pose)
        seen_ever |= seen
        slam.process_scan((k + 1) * dt, z)
        truth.append(pose)
        track.append(slam.pose)

# %%
# The result: pose error and NEES, and each true landmark's nearest mapped one.
err = slam.pose - pose
err[2] = (err[2] + np.pi) % (2 * np.pi) - np.pi
nees = float(err @ np.linalg.solve(slam.pose_cov, err))
mapped = slam.landmarks()
nearest = np.min(np.linalg.norm(landmarks[seen_ever][:, None] - mapped[None], axis=2), axis=1)
print(f'final position error {np.hypot(*err[:2]):.3f} m, heading error {math.degrees(abs(err[2])):.3f} deg')
print(f'final pose NEES {nees:.2f}')
print(f'landmarks mapped {len(mapped)} of {seen_ever.sum()} seen, RMS error {np.sqrt(np.mean(nearest**2)):.3f} m')
print(f'switches to the particle filter {sum(e.kind == "to_pf" for e in slam.events)}')

if args.out:
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    truth, track = np.array(truth), np.array(track)
    fig, ax = plt.subplots(figsize=(6, 6))
    ax.plot(*landmarks.T, 'k^', label='landmarks')
    ax.plot(*mapped.T, 'C3+', ms=10, label='mapped')
    ax.plot(truth[:, 0], truth[:, 1], 'k-', lw=0.8, label='laser, true')
    ax.plot(track[:, 0], track[:, 1], 'C0--', lw=0.8, label='laser, estimate')
    ax.set_aspect('equal')
    ax.set_xlabel('x (m)')
    ax.set_ylabel('y (m)')
    ax.legend(fontsize=8)
    fig.savefig(args.out, dpi=100)
    print(f'figure {args.out}')
