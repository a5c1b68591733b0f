"""A synthetic sea at a constant ship density: the layout on which the fusion core's growth is measured.

The Solent layout (``bench.solent_layout``) stacks 84 minutes of reports into one picture, so its
candidate pairs grow as n² with the track count n. A real picture grows by covering more sea: here
``n`` tracks are n/2 ships in a square whose side grows as √n, so the density stays ``density``
ships per km². The ships are drawn as the synthetic AIS generator (``track_core.ais.synthetic``)
draws them: a share ``moored`` at a point within 300 m (1σ) of a port (one port per
``ships_per_port`` ships, so harbours stay as crowded at every size), the others sailing a
straight course at 4–20 kn. Each ship is one track of each of the ``ais`` scenario's sources
(``track_core.ais.RADAR``/``PATROL``: 1σ 15 × 8 m and 60 × 20 m, fixed bearing per track), and
every ``tick`` each track reports its ship's position with noise drawn from its covariance.
"""

from __future__ import annotations

import numpy as np

from track_core.ais import PATROL, RADAR
from track_core.ais.reader import KNOT

DENSITY = 4.0          # ships per km²: a busy approach
SHIPS_PER_PORT = 100
MOORED = 0.3


def _covariances(n: int, sigma_major: float, sigma_minor: float, rng: np.random.Generator) -> np.ndarray:
    th = rng.uniform(0.0, np.pi, n)
    c, s = np.cos(th), np.sin(th)
    U = np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)     # (n, 2, 2) rotations
    D = np.zeros((n, 2, 2))
    D[:, 0, 0], D[:, 1, 1] = sigma_major**2, sigma_minor**2
    return U @ D @ np.swapaxes(U, 1, 2)


class SyntheticSea:
    """n tracks (n/2 ships × radar and patrol) on a square sea at ``density`` ships per km²."""

    def __init__(self, n_tracks: int, rng: np.random.Generator, density: float = DENSITY,
                 moored: float = MOORED, ships_per_port: int = SHIPS_PER_PORT) -> None:
        ships = n_tracks // 2
        self.rng, self.ships = rng, ships
        self.side = 1000.0 * np.sqrt(ships / density)                      # metres
        ports = rng.uniform(0.0, self.side, (max(1, ships // ships_per_port), 2))
        at_port = rng.random(ships) < moored
        self.pos = rng.uniform(0.0, self.side, (ships, 2))
        self.pos[at_port] = ports[rng.integers(len(ports), size=int(at_port.sum()))] \
            + 300.0 * rng.standard_normal((int(at_port.sum()), 2))
        heading = rng.uniform(0.0, 2 * np.pi, ships)
        speed = np.where(at_port, 0.0, rng.uniform(4.0, 20.0, ships) * KNOT)
        self.vel = speed[:, None] * np.stack([np.sin(heading), np.cos(heading)], 1)
        self.R = np.concatenate([_covariances(ships, RADAR.sigma_major, RADAR.sigma_minor, rng),
                                 _covariances(n_tracks - ships, PATROL.sigma_major, PATROL.sigma_minor, rng)])
        self.ids = [f'r{k:05d}' for k in range(ships)] + [f'p{k:05d}' for k in range(n_tracks - ships)]
        self.sources = ['/radar'] * ships + ['/patrol'] * (n_tracks - ships)
        self._L = np.linalg.cholesky(self.R)
        self._ship = np.concatenate([np.arange(ships), np.arange(n_tracks - ships) % max(ships, 1)])

    def step(self, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """Move the ships ``dt`` seconds; → every track's report (μ (n, 2), R (n, 2, 2))."""
        self.pos += self.vel * dt
        noise = np.einsum('nij,nj->ni', self._L, self.rng.standard_normal((len(self.ids), 2)))
        return self.pos[self._ship] + noise, self.R
