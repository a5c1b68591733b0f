"""The real ships as ground truth, and simulated report sources observing them.

:class:`ShipTruth` — the AIS reports of each ship projected to east/north metres
(:mod:`.projection`) and linearly interpolated in time. A ship exists from its first to its
last AIS report; inside a gap between two reports longer than ``max_gap`` (400 s: moored
class-A ships report every 3 min, so one lost report is bridged) its position is unknown and no
source reports it.

:class:`SourceModel` — one surveillance source: a report grid ``t_start + offset + k·period``;
at each instant it reports every ship it sees (position known, within ``max_range`` of its
``site``), each report independently missing with probability ``dropout``; the report is the
true position plus Gaussian noise whose 2σ ellipse is the one the report carries (eqs. 56–59:
1σ semi-axes ``sigma_major``, ``sigma_minor``; consistent noise, the covariance is the true
error covariance). The major axis bearing is

- ``'fixed'``: ``bearing_deg`` clockwise from north for every report;
- ``'radial'``: across the line of sight from ``site`` (a radar measures range well and
  bearing poorly, so its ellipse is long across the beam);
- ``'random'``: uniform in [0°, 180°) per report (a moving platform sees each ship from a
  changing direction).

Each source numbers the ships it reports with its **own local track ids** (``id_prefix`` +
three digits, in an order shuffled by the source's generator); the MMSI is kept in
:attr:`SourceReports.mmsi` as truth for evaluation and is never part of a report.

Defaults (:data:`RADAR`, :data:`PATROL`): a coastal radar at Calshot (the mouth of
Southampton Water) with 1σ 15 m × 8 m ellipses across the beam every 5 s, 2 % missed
reports; a patrol aircraft with 1σ 60 m × 20 m ellipses at random bearings every 30 s, 25 %
missed reports. The 30 s patrol grid falls on the 5 s radar grid, so the two share an instant
every 30 s.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, replace

import numpy as np

from track_core.ais.projection import LocalTangentPlane
from track_core.ais.reader import AisData
from track_core.geofeasibility.ellipse import ellipse_to_gaussian

ORIENTATIONS = ('fixed', 'radial', 'random')
CALSHOT = (50.8184, -1.3072)  # lat, lon of the default radar site


class ShipTruth:
    """Per-ship interpolated east/north positions; ``positions(t)`` is vectorised over ships and times."""

    def __init__(self, data: AisData, plane: LocalTangentPlane | None = None, max_gap: float = 400.0) -> None:
        if not max_gap > 0:
            raise ValueError(f'max_gap must be > 0 s, got {max_gap}')
        self.plane = plane if plane is not None else LocalTangentPlane(*data.centroid())
        self.max_gap = float(max_gap)
        self.mmsi = data.ships
        xy = self.plane.forward(data.lat, data.lon)
        order = np.lexsort((data.t, data.mmsi))
        _, start = np.unique(data.mmsi[order], return_index=True)
        bounds = list(itertools.pairwise([*start.tolist(), order.size]))
        self.times = [data.t[order[a:b]] for a, b in bounds]
        self.xy = [xy[order[a:b]] for a, b in bounds]
        self.t_end = float(data.t[-1]) if data.t.size else 0.0

    def __len__(self) -> int:
        return self.mmsi.size

    def positions(self, t) -> np.ndarray:
        """(S, K, 2) positions at times ``t`` (K,); NaN where a ship's position is unknown."""
        t = np.atleast_1d(np.asarray(t, float))
        out = np.full((len(self), t.size, 2), np.nan)
        for s, (ts, xy) in enumerate(zip(self.times, self.xy, strict=True)):  # loop over ships, not reports
            j = np.searchsorted(ts, t, side='right')          # ts[j-1] <= t < ts[j]
            inside = (t >= ts[0]) & (t <= ts[-1])
            lo = np.clip(j - 1, 0, ts.size - 1)
            hi = np.clip(j, 0, ts.size - 1)
            gap = ts[hi] - ts[lo]
            ok = inside & ((gap <= self.max_gap) | (t == ts[lo]))   # a report itself is always known
            w = np.where(gap > 0, (t - ts[lo]) / np.where(gap > 0, gap, 1.0), 0.0)[:, None]
            p = (1.0 - w) * xy[lo] + w * xy[hi]
            out[s, ok] = p[ok]
        return out


@dataclass(frozen=True)
class SourceModel:
    """A simulated report source (see the module docstring). Lengths in metres, times in seconds."""

    name: str = 'radar'
    id_prefix: str = 'r'
    period: float = 5.0
    offset: float = 0.0
    sigma_major: float = 15.0
    sigma_minor: float = 8.0
    orientation: str = 'radial'
    bearing_deg: float = 0.0
    site: tuple[float, float] | None = CALSHOT   # (lat, lon) of the sensor; None: the projection origin
    max_range: float | None = None
    dropout: float = 0.02

    def __post_init__(self) -> None:
        if not self.period > 0 or not self.offset >= 0:
            raise ValueError(f'{self.name}: need period > 0 and offset >= 0, got {self.period}, {self.offset}')
        if not 0 < self.sigma_minor <= self.sigma_major or not np.isfinite(self.sigma_major):
            raise ValueError(f'{self.name}: need 0 < sigma_minor <= sigma_major (finite), '
                             f'got {self.sigma_minor}, {self.sigma_major}')
        if self.orientation not in ORIENTATIONS:
            raise ValueError(f'{self.name}: orientation {self.orientation!r} is not one of {", ".join(ORIENTATIONS)}')
        if not 0.0 <= self.dropout < 1.0:
            raise ValueError(f'{self.name}: dropout must be in [0, 1), got {self.dropout}')
        if self.max_range is not None and not self.max_range > 0:
            raise ValueError(f'{self.name}: max_range must be > 0 or None, got {self.max_range}')

    def scaled(self, k: float) -> SourceModel:
        """The same source with both semi-axes multiplied by ``k`` (the noise sweep)."""
        return replace(self, sigma_major=self.sigma_major * k, sigma_minor=self.sigma_minor * k)


RADAR = SourceModel()
PATROL = SourceModel(name='patrol', id_prefix='p', period=30.0, sigma_major=60.0, sigma_minor=20.0,
                     orientation='random', site=None, dropout=0.25)


@dataclass
class SourceReports:
    """All reports of one source: report k is track ``track[k]`` (local id ``ids[track[k]]``) at ``t[k]``."""

    name: str
    ids: list[str]
    mmsi: np.ndarray      # (n_tracks,) truth: the ship behind each local track (never reported)
    t: np.ndarray         # (m,)
    track: np.ndarray     # (m,) int
    mu: np.ndarray        # (m, 2) reported position
    R: np.ndarray         # (m, 2, 2) reported covariance (2σ ellipse: (x−μ)ᵀR⁻¹(x−μ) ≤ 4)
    truth: np.ndarray     # (m, 2) true position (evaluation only)

    def __len__(self) -> int:
        return self.t.size


def report_times(model: SourceModel, t_start: float, t_end: float) -> np.ndarray:
    """The source's grid ``t_start + offset + k·period`` (k ≥ 0) up to ``t_end`` inclusive."""
    n = int(np.floor((t_end - t_start - model.offset) / model.period + 1e-9)) + 1
    return t_start + model.offset + model.period * np.arange(max(n, 0))


def simulate_source(truth: ShipTruth, model: SourceModel, rng: np.random.Generator,
                    t_start: float = 0.0, t_end: float | None = None) -> SourceReports:
    """Every report of ``model`` on the real ships between ``t_start`` and ``t_end`` (default: the data's end)."""
    t_end = truth.t_end if t_end is None else float(t_end)
    times = report_times(model, t_start, t_end)
    pos = truth.positions(times)                                   # (S, K, 2)
    seen = np.all(np.isfinite(pos), axis=-1)
    site = np.zeros(2) if model.site is None else truth.plane.forward(*model.site)
    if model.max_range is not None:
        with np.errstate(invalid='ignore'):
            seen &= np.linalg.norm(pos - site, axis=-1) <= model.max_range
    seen &= rng.random(seen.shape) >= model.dropout
    ship, k = np.nonzero(seen)                                     # report order: ship, then time
    true_xy = pos[ship, k]
    m = ship.size
    if model.orientation == 'fixed':
        phi = np.full(m, np.radians(model.bearing_deg))
    elif model.orientation == 'radial':
        d = true_xy - site
        phi = np.arctan2(d[:, 0], d[:, 1]) + 0.5 * np.pi       # across the line of sight
    else:
        phi = rng.uniform(0.0, np.pi, m)
    _, R = ellipse_to_gaussian(np.zeros(m), np.zeros(m), 2 * model.sigma_major, 2 * model.sigma_minor, phi)
    R = R.reshape(m, 2, 2)
    noise = np.einsum('mij,mj->mi', np.linalg.cholesky(R), rng.standard_normal((m, 2)))
    # local track ids: the ships this source ever reports, numbered in a shuffled order
    seen_ships = np.unique(ship)
    perm = rng.permutation(seen_ships.size)
    local = np.empty(len(truth), int)
    local[seen_ships] = perm
    ids = [f'{model.id_prefix}{i:03d}' for i in range(seen_ships.size)]
    mmsi = np.empty(seen_ships.size, np.int64)
    mmsi[perm] = truth.mmsi[seen_ships]
    order = np.lexsort((local[ship], k))                          # time, then local id
    return SourceReports(model.name, ids, mmsi, times[k][order], local[ship][order], (true_xy + noise)[order],
                         R[order], true_xy[order])
