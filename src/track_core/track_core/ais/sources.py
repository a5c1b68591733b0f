"""The real ships as ground truth, and simulated report sources observing them.

:class:`ShipTruth`: the AIS reports of each ship projected to east/north metres (:mod:`.projection`)
and linearly interpolated in time, from its first to its last report; inside a gap longer than the
ship's gap limit its position is unknown and no source reports it. ``max_gap=None`` (default)
derives the limit per ship: ``gap_factor`` (20) × its median report interval, at most ``gap_cap``
(3600 s); a ship with one report gets the others' median. A number is one limit for every ship.
:meth:`ShipTruth.gap_summary` reports the limits and the bridged share of the ships' time.

:class:`SourceModel`: one surveillance source, a report grid ``t_start + offset + k·period``; at
each instant it reports every ship it sees (position known, within ``max_range`` of its ``site``),
each report missing with probability ``dropout``; a report is the true position plus Gaussian noise
whose 2σ ellipse is the one it carries (eqs. 56–59: 1σ semi-axes ``sigma_major``, ``sigma_minor``;
consistent noise). The major axis: ``'fixed'`` (``bearing_deg`` clockwise from north), ``'radial'``
(across the line of sight from ``site``) or ``'random'`` (uniform in [0°, 180°) per report). Each
source numbers the ships with its own local track ids (``id_prefix`` + three digits, shuffled); the
MMSI is kept in :attr:`SourceReports.mmsi` for evaluation only.

Sites: ``(lat, lon)``, ``None`` (the projection origin) or ``'hull:<bearing>'``: where the ray from
the mean report position at that bearing leaves the traffic's convex hull, moved to the nearest
report when that point is over ``SITE_SNAP_M`` (10 km) from every report (:func:`resolve_site`).
Defaults (:data:`RADAR`, :data:`PATROL`): a coastal radar at ``'hull:280'``, 1σ 15 m × 8 m across
the beam every 5 s, 2 % missed; a patrol aircraft, 1σ 60 m × 20 m at random bearings every 30 s, 25
% missed (the two share an instant every 30 s). Solent figures: docs/results/fusion.md.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from track_core.ais.projection import LocalTangentPlane, extent_problem
from track_core.ais.reader import AisData
from track_core.geofeasibility.ellipse import ellipse_to_gaussian

if TYPE_CHECKING:   # a type only: importing PROJ is for the nodes that project through a datum
    from track_core.ais.datum import Datum

ORIENTATIONS = ('fixed', 'radial', 'random')
CALSHOT = (50.8184, -1.3072)  # lat, lon of the former fixed radar site (Solent only)
GAP_FACTOR = 20.0
GAP_CAP = 3600.0
SIM_CELLS = 4_000_000  # ships × instants simulated per block (bounds simulate_source's memory)


def _hull_bearing(site: str, name: str = 'site') -> float:
    kind, _, value = site.partition(':')
    try:
        bearing = float(value)
    except ValueError:
        bearing = math.nan
    if kind.strip() != 'hull' or not math.isfinite(bearing):
        raise ValueError(f"{name}: site {site!r} is not (lat, lon), None or 'hull:<bearing in degrees>'")
    return bearing


class ShipTruth:
    """Per-ship interpolated east/north positions; ``positions(t)`` is vectorised over ships and times."""

    def __init__(self, data: AisData, plane: LocalTangentPlane | Datum | None = None, max_gap: float | None = None,
                 *, gap_factor: float = GAP_FACTOR, gap_cap: float = GAP_CAP) -> None:
        """``plane``: the projection to map (``forward``, ``inverse``, ``lat0``, ``lon0``): a node's run
        datum (``datum.Datum``), or the tangent plane at the data centroid (the default)."""
        if max_gap is not None and not max_gap > 0:
            raise ValueError(f'max_gap must be > 0 s or None (derived per ship), got {max_gap}')
        if not gap_factor > 0 or not gap_cap > 0:
            raise ValueError(f'gap_factor and gap_cap must be > 0, got {gap_factor}, {gap_cap}')
        self.plane = plane if plane is not None else LocalTangentPlane(*data.centroid())
        far = extent_problem(data.lat, data.lon, self.plane.lat0, self.plane.lon0)
        if far is not None:
            name = data.path.name if data.path is not None else 'AIS data'
            raise ValueError(f'{name}: {far}')
        self.mmsi = data.ships
        self.xy_all = xy = self.plane.forward(data.lat, data.lon)
        order = np.lexsort((data.t, data.mmsi))
        _, start = np.unique(data.mmsi[order], return_index=True)
        bounds = list(itertools.pairwise([*start.tolist(), order.size]))
        self.times = [data.t[order[a:b]] for a, b in bounds]
        self.xy = [xy[order[a:b]] for a, b in bounds]
        self.t_end = float(data.t[-1]) if data.t.size else 0.0
        # per-ship median report interval (vectorised over all reports: segment medians by ship)
        self.median_interval = np.full(len(self), np.nan)
        dt = np.diff(data.t[order])
        ship = np.searchsorted(start, np.arange(order.size), side='right') - 1
        seg = ship[1:] == ship[:-1]
        if seg.any():
            s_seg, d_seg = ship[1:][seg], dt[seg]
            o = np.lexsort((d_seg, s_seg))
            s_seg, d_seg = s_seg[o], d_seg[o]
            u, first, cnt = np.unique(s_seg, return_index=True, return_counts=True)
            lo, hi = first + (cnt - 1) // 2, first + cnt // 2
            self.median_interval[u] = 0.5 * (d_seg[lo] + d_seg[hi])
        if max_gap is None:
            lim = np.minimum(gap_factor * self.median_interval, gap_cap)
            fill = float(np.nanmedian(lim)) if np.isfinite(lim).any() else gap_cap
            self.gap_limit = np.where(np.isfinite(lim), lim, fill)
            self.gap_rule = f'derived: min({gap_factor:g} × median interval, {gap_cap:g} s) per ship'
        else:
            self.gap_limit = np.full(len(self), float(max_gap))
            self.gap_rule = f'fixed: {float(max_gap):g} s'
        self.max_gap = float(np.max(self.gap_limit)) if len(self) else 0.0

    def gap_summary(self) -> dict[str, float | str]:
        """The gap rule, the limits (min/median/max) and the share of gaps and ship-time bridged."""
        gaps = [np.diff(t) for t in self.times]
        lims = [np.full(g.size, lim) for g, lim in zip(gaps, self.gap_limit, strict=True)]
        g, lim = (np.concatenate(x) if x else np.zeros(0) for x in (gaps, lims))
        span = float(g.sum())
        return {'rule': self.gap_rule, 'limit_min_s': float(self.gap_limit.min()),
                'limit_median_s': float(np.median(self.gap_limit)), 'limit_max_s': float(self.gap_limit.max()),
                'median_interval_s': float(np.nanmedian(self.median_interval)) if g.size else float('nan'),
                'gaps_bridged': float(np.mean(g <= lim)) if g.size else 1.0,
                'time_known': float(g[g <= lim].sum() / span) if span > 0 else 1.0}

    def __len__(self) -> int:
        return self.mmsi.size

    def positions(self, t) -> np.ndarray:
        """(S, K, 2) positions at times ``t`` (K,); NaN where a ship's position is unknown."""
        t = np.atleast_1d(np.asarray(t, float))
        out = np.full((len(self), t.size, 2), np.nan)
        for s, (ts, xy, max_gap) in enumerate(zip(self.times, self.xy, self.gap_limit, strict=True)):  # ships
            j = np.searchsorted(ts, t, side='right')          # ts[j-1] <= t < ts[j]
            inside = (t >= ts[0]) & (t <= ts[-1])
            lo = np.clip(j - 1, 0, ts.size - 1)
            hi = np.clip(j, 0, ts.size - 1)
            gap = ts[hi] - ts[lo]
            ok = inside & ((gap <= max_gap) | (t == ts[lo]))   # a report itself is always known
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
    site: tuple[float, float] | str | None = 'hull:280'   # (lat, lon), 'hull:<bearing>' or None (origin)
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
        if isinstance(self.site, str):
            _hull_bearing(self.site, self.name)

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


def hull_point(xy: np.ndarray, bearing_deg: float) -> np.ndarray:
    """Where the ray from the mean of ``xy`` (n, 2) at ``bearing_deg`` (from north) leaves their convex hull."""
    from scipy.spatial import ConvexHull, QhullError

    c = xy.mean(0)
    u = np.array([np.sin(np.radians(bearing_deg)), np.cos(np.radians(bearing_deg))])
    try:
        hull = ConvexHull(xy)
    except (QhullError, ValueError):               # fewer than 3 distinct or collinear points
        return c + u * max(float(np.max((xy - c) @ u)), 0.0)
    p, q = xy[hull.simplices[:, 0]], xy[hull.simplices[:, 1]]
    e, w = q - p, p - c
    den = u[0] * e[:, 1] - u[1] * e[:, 0]           # cross(u, e)
    with np.errstate(divide='ignore', invalid='ignore'):
        s = (w[:, 0] * e[:, 1] - w[:, 1] * e[:, 0]) / den   # along the ray
        r = (w[:, 0] * u[1] - w[:, 1] * u[0]) / den         # along the edge
    ok = np.isfinite(s) & (s >= 0) & (r >= -1e-9) & (r <= 1 + 1e-9)
    return c + u * float(np.max(s[ok])) if ok.any() else c


SITE_SNAP_M = 10_000.0  # a hull point farther than this from every report moves to the nearest report


def traffic_point(xy: np.ndarray, bearing_deg: float, snap: float = SITE_SNAP_M) -> np.ndarray:
    """``hull_point``, or the report of ``xy`` nearest to it when none is within ``snap`` metres (module docstring)."""
    p = hull_point(xy, bearing_deg)
    d = np.hypot(*(xy - p).T)
    k = int(np.argmin(d))
    return p if d[k] <= snap else xy[k].astype(float)


def resolve_site(truth: ShipTruth, site) -> np.ndarray:
    """East/north metres of a ``SourceModel.site`` (see the module docstring) in ``truth``'s plane."""
    if site is None:
        return np.zeros(2)
    if isinstance(site, str):
        return traffic_point(truth.xy_all, _hull_bearing(site)) if len(truth.xy_all) else np.zeros(2)
    return truth.plane.forward(*site)


def report_times(model: SourceModel, t_start: float, t_end: float) -> np.ndarray:
    """The source's grid ``t_start + offset + k·period`` (k ≥ 0) up to ``t_end`` inclusive."""
    n = int(np.floor((t_end - t_start - model.offset) / model.period + 1e-9)) + 1
    return t_start + model.offset + model.period * np.arange(max(n, 0))


def simulate_source(truth: ShipTruth, model: SourceModel, rng: np.random.Generator,
                    t_start: float = 0.0, t_end: float | None = None, *, block_cells: int = SIM_CELLS) -> SourceReports:
    """Every report of ``model`` on the real ships between ``t_start`` and ``t_end`` (default: the data's end).

    The grid is simulated in blocks of at most ``block_cells`` ships × instants (memory bounded by
    the block, not the duration); within a block the draws are dropouts, bearings, noise in
    that order, so a run that fits one block draws exactly what the unblocked simulation drew.
    """
    t_end = truth.t_end if t_end is None else float(t_end)
    times = report_times(model, t_start, t_end)
    site = resolve_site(truth, model.site)
    step = max(1, int(block_cells) // max(len(truth), 1))
    parts = []
    for k0 in range(0, times.size, step):               # blocks of instants (a few, not one per instant)
        parts.append(_simulate_block(truth, model, rng, times, k0, min(k0 + step, times.size), site))
    ship, k, true_xy, mu, R = (np.concatenate([p[i] for p in parts]) if parts else np.zeros(0)
                               for i in range(5))
    ship, k = ship.astype(int), k.astype(int)
    true_xy, mu, R = true_xy.reshape(-1, 2), mu.reshape(-1, 2), R.reshape(-1, 2, 2)
    # local track ids: the ships this source ever reports, numbered in a shuffled order
    seen_ships = np.unique(ship)
    perm = rng.permutation(seen_ships.size)
    local = np.empty(len(truth), int)
    local[seen_ships] = perm
    ids = [f'{model.id_prefix}{i:03d}' for i in range(seen_ships.size)]
    mmsi = np.empty(seen_ships.size, np.int64)
    mmsi[perm] = truth.mmsi[seen_ships]
    order = np.lexsort((local[ship], k))                          # time, then local id
    return SourceReports(model.name, ids, mmsi, times[k][order], local[ship][order], mu[order], R[order],
                         true_xy[order])


def _simulate_block(truth: ShipTruth, model: SourceModel, rng: np.random.Generator, times: np.ndarray,
                    k0: int, k1: int, site: np.ndarray):
    """(ship, instant index, true xy, reported xy, R) of the reports at ``times[k0:k1]``, ship-major order."""
    pos = truth.positions(times[k0:k1])                            # (S, K, 2)
    seen = np.all(np.isfinite(pos), axis=-1)
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
    return ship, k + k0, true_xy, true_xy + noise, R
