"""SS-PF tracking a smart target from sonar contacts (``track_core.sonar``)
=========================================================================

An observer AUV follows the paper's two-manoeuvre path and listens to a target every second. The
target evades when it hears an active ping, so every ping has a price. The SS-PF (the smart-target
model as its motion model) uses eq. 7 to decide, step by step, whether the next contact is a passive
bearing or an active bearing and range: it pings only when its covariance is farther than δ from the
desired covariance P_D (spectral norm).

The script prints the final position error, the filter's own position NEES (for a consistent
filter a χ² draw with 2 degrees of freedom) and the number of pings.

    python examples/sonar_smart_target.py [--seed 1] [--out sonar.png]
"""

import argparse

import numpy as np

from track_core.sonar import Scenario, SensorMode, SmartTarget, SmartTargetParams, make_tracker, measure, residual

ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
ap.add_argument('--seed', type=int, default=1)
ap.add_argument('--out', help='write a figure of the run to this PNG file (needs matplotlib)')
args = ap.parse_args()

# %%
# The scenario: Table 1 sonar (1° bearings, 5 m ranges, T = 1 s), 40 steps, a 20 m / 2 m/s prior.
scenario = Scenario()
sonar = scenario.params
rng_target, rng_noise, rng_filter = (np.random.default_rng(s) for s in np.random.SeedSequence(args.seed).spawn(3))
target = SmartTarget(np.array(scenario.target_x0), sonar=sonar, params=SmartTargetParams())

# %%
# The tracker: SS-PF with eq. 7 scheduling (δ = 50, the closed-loop setting) and the smart-target model.
tracker = make_tracker('ss-pf', sonar, rng_filter, delta=50.0, target_model=SmartTargetParams())
tracker.initialize(scenario.draw_prior_mean(rng_noise, target.x), scenario.prior_cov)
target.step(rng_target, False, scenario.observer.position(0.0))  # x0 -> x1

# %%
# The loop: the tracker picks the sensor, the sonar makes a contact, the tracker steps on it, and
# the target hears the ping (or not) before it moves on.
noise_std = np.array([sonar.sigma_b, sonar.sigma_d])
truth, track, observer = [], [], []
for t in scenario.times:
    obs = scenario.observer.position(t)
    mode = tracker.next_mode
    clean = measure(target.x, obs, mode)  # bearing, or bearing and range
    z = residual(clean + noise_std[:clean.size] * rng_noise.standard_normal(clean.size), np.zeros_like(clean))
    estimate = tracker.step(z, mode, obs)
    truth.append(target.x.copy())
    track.append(estimate.mean)
    observer.append(obs)
    target.step(rng_target, mode is SensorMode.ACTIVE, obs)

# %%
# The result: the final position error against the filter's own covariance.
pos = [0, 2]
d = (truth[-1] - estimate.mean)[pos]
nees_pos = float(d @ np.linalg.solve(estimate.cov[np.ix_(pos, pos)], d))
print(f'final position error {np.hypot(*d):.2f} m')
print(f'final position NEES {nees_pos:.2f}')
print(f'pings {target.pings} of {scenario.n_steps} steps, heard {target.detections}')

if args.out:
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    truth, track, observer = np.array(truth), np.array(track), np.array(observer)
    fig, ax = plt.subplots(figsize=(6, 5))
    ax.plot(truth[:, 0], truth[:, 2], 'k-', label='smart target')
    ax.plot(track[:, 0], track[:, 2], 'C0.-', label='SS-PF estimate')
    ax.plot(observer[:, 0], observer[:, 1], 'C2--', label='observer')
    ax.set_xlabel('x east (m)')
    ax.set_ylabel('y north (m)')
    ax.set_aspect('equal')
    ax.legend()
    fig.savefig(args.out, dpi=100)
    print(f'figure {args.out}')
