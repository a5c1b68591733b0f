"""Geofeasibility scores and the pair associator (``track_core.geofeasibility``, ``track_core.fusion``)
=====================================================================================================

Two sources report tracks once a second: a coastal radar (σ 30 m along x, 10 m along y) sees a ship
and a decoy 500 m to its north, and an AIS-like source (σ 10 m) sees the ship alone. Each report is the
true position plus a draw from the report's own covariance, as an honest tracker's would be.

First the instant scores of the ship pair by two methods: GLR (eq. 71, exp(−½ Δᵀ (R₁ + R₂)⁻¹ Δ)) and
the exact overlap of the two 2σ ellipses (eq. 49). For a pair of one ship with honest covariances Δ is
N(0, R₁ + R₂), so the Mahalanobis term is χ² with 2 degrees of freedom and the GLR score is uniform on
(0, 1): its mean over many instants is 1/2. Then ``PairAssociator`` (what the ``fusion`` node runs)
combines each pair's last 10 exact scores by their geometric mean and associates the pairs at or above
the threshold; the decoy's ellipses never touch the AIS ship's, so its exact score is 0 at every instant.

    python examples/fusion_pair_score.py [--seed 1] [--out fusion.png]
"""

import argparse

import numpy as np

from track_core.fusion import PairAssociator, TrackReport
from track_core.geofeasibility import score

ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
ap.add_argument('--seed', type=int, default=1)
ap.add_argument('--out', help='write a figure of the scores to this PNG file (needs matplotlib)')
args = ap.parse_args()
rng = np.random.default_rng(args.seed)

# %%
# The world: a ship sailing east at 8 m/s, a decoy 500 m north of it, 120 reports of each track.
times = np.arange(1.0, 121.0)
ship = np.stack([8.0 * times, np.zeros_like(times)], axis=1)
decoy = ship + np.array([0.0, 500.0])
radar_cov = np.array([[30.0**2, 0.0], [0.0, 10.0**2]])  # a long-range radar: poor along x
ais_cov = np.diag([10.0**2, 10.0**2])


def report(t, truth, R):
    """A track report: the truth plus a draw of its covariance R, and R itself."""
    return TrackReport(t, truth + rng.multivariate_normal(np.zeros(2), R), R)


# %%
# The associator: exact scores, a geometric mean over 10 instants, threshold 0.5.
associator = PairAssociator(method='exact', combine='geometric', window=10, threshold=0.5)
glr, exact, combined = [], [], {'ship': [], 'decoy': []}
associated = {'ship': 0, 'decoy': 0}
for k, t in enumerate(times):
    reports = {'radar/ship': report(t, ship[k], radar_cov), 'radar/decoy': report(t, decoy[k], radar_cov),
               'ais/ship': report(t, ship[k], ais_cov)}
    for track_id, r in reports.items():
        associator.update(track_id.split('/')[0], track_id, r)
    a, b = reports['radar/ship'], reports['ais/ship']
    glr.append(float(score(a.mu, a.R, b.mu, b.R, method='glr')))
    exact.append(float(score(a.mu, a.R, b.mu, b.R, method='exact')))
    instant = associator.score(t)
    # The scored pairs are the candidates (ellipses that may overlap); a pair not listed scored 0.
    by_pair = {frozenset((p.a, p.b)): p for p in instant.all_pairs()}
    for name, pair in (('ship', by_pair[frozenset(('radar/ship', 'ais/ship'))]),
                       ('decoy', by_pair[frozenset(('radar/decoy', 'ais/ship'))])):
        combined[name].append(pair.combined)
        associated[name] += pair.associated

# %%
# The result.
n = len(times)
se = np.sqrt(1 / 12 / n)  # standard error of the mean of n uniform draws
print(f'ship pair: mean GLR score {np.mean(glr):.3f} over {n} instants (honest pair: 0.5, standard error {se:.3f})')
print(f'ship pair: mean exact score {np.mean(exact):.3f}, associated at {associated["ship"]} of {n} instants')
print(f'decoy pair: largest combined score {max(combined["decoy"]):.3f}, associated at {associated["decoy"]} '
      f'of {n} instants')

if args.out:
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4))
    ax.plot(times, glr, 'C1.', ms=3, label='ship pair, GLR instant score')
    ax.plot(times, exact, 'C0.', ms=3, label='ship pair, exact instant score')
    ax.plot(times, combined['ship'], 'C0-', label='ship pair, combined (10 instants)')
    ax.plot(times, combined['decoy'], 'C3-', label='decoy pair, combined')
    ax.axhline(0.5, color='k', lw=0.8, ls='--', label='threshold')
    ax.set_xlabel('t (s)')
    ax.set_ylabel('score')
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(args.out, dpi=100)
    print(f'figure {args.out}')
