"""A handheld RFID reader's particle filter walking a person to a tag (``track_core.rfid``)
======================================================================================

The reader measures, for each 0.5 m step the person walks, the phase difference dφ of the tag's reply
between the step's start and end: dφ = (4π/λ)(|E| − |S|) (eq. 6), the change of the distance to the
tag in units of the carrier's half wavelength, so it says how much closer the step went but not where
the tag is. The particle filter (eqs. 15–24) holds the person's position and heading in a frame with
the tag at the origin; each dφ weights the particles, and the filter suggests the next turn towards
its tag estimate (eq. 24). The person turns (with an 11.5° error), steps (with a 10 cm error) and the
loop goes on until the filter puts the tag within one step.

The script prints how many steps that took and the true distance to the tag at the end.

    python examples/rfid_tag_search.py [--seed 1] [--out rfid.png]
"""

import argparse
import math

import numpy as np

from track_core.rfid import PFParams, PhaseModel, RfidParticleFilter

ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
ap.add_argument('--seed', type=int, default=1)
ap.add_argument('--out', help='write a figure of the walk to this PNG file (needs matplotlib)')
args = ap.parse_args()
rng_world, rng_filter = (np.random.default_rng(s) for s in np.random.SeedSequence(args.seed).spawn(2))

# %%
# The world: the tag at the origin, the person 8 m away, facing within 60° of the tag (the reader's
# beam: the filter's prior puts the tag within ±90° of the heading and 0.3–15 m away).
phase = PhaseModel()  # 866.3 MHz, per-read phase noise s_θ = 5.5°
params = PFParams()   # 100 particles, the paper's step and heading errors
start_bearing = rng_world.uniform(-math.pi, math.pi)
x, y = 8.0 * math.cos(start_bearing), 8.0 * math.sin(start_bearing)
heading = math.atan2(-y, -x) + rng_world.uniform(-math.pi / 3, math.pi / 3)

# %%
# The loop: turn as suggested, walk one step, measure dφ (a difference of two reads: noise √2 s_θ),
# update the filter.
pf = RfidParticleFilter(params, phase, rng_filter)
path = [(x, y)]
turn, walked, step = 0.0, 0.0, 0
while step < 100:
    step += 1
    heading += turn + params.s_a * rng_world.standard_normal()
    length = params.s_step + params.s_r * rng_world.standard_normal()
    before = math.hypot(x, y)
    x, y = x + length * math.cos(heading), y + length * math.sin(heading)
    walked += length
    path.append((x, y))
    dphi = phase.k * (math.hypot(x, y) - before) + math.sqrt(2) * phase.s_theta * rng_world.standard_normal()
    pf.update(dphi, turn)
    distance, turn = pf.tag_estimate()  # the filter's distance to the tag, and the turn towards it
    if distance < params.s_step:
        break

# %%
# The result.
print(f'steps {step} (at most 100), walked {walked:.1f} m from 8.0 m away')
print(f'filter distance to the tag {distance:.2f} m')
print(f'true distance to the tag {math.hypot(x, y):.2f} m')

if args.out:
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    path = np.array(path)
    fig, ax = plt.subplots(figsize=(5, 5))
    ax.plot(path[:, 0], path[:, 1], 'C0.-', label='walk')
    ax.plot(0, 0, 'k*', ms=12, label='tag')
    ax.plot(*path[0], 'C0o', label='start')
    ax.set_xlabel('x (m)')
    ax.set_ylabel('y (m)')
    ax.set_aspect('equal')
    ax.legend()
    fig.savefig(args.out, dpi=100)
    print(f'figure {args.out}')
