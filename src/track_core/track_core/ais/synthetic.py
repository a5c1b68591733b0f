"""A seeded synthetic AIS file: any coast, long report intervals, a large spread, known defects.

Stands in for AIS data we do not have (the issue-16 data set of another sea: 4.5 days, 256
vessels, ~12-minute reports over 200 km). :func:`synthetic_ais` draws, with the given
``numpy.random.Generator``:

- ``n_ships`` ships (MMSI 200000000 + i), each present for a random part of the ``duration``
  (start uniform, length ``presence`` × duration on average, exponential, at least one hour);
- a share ``moored`` of them at a fixed point in one of ``n_ports`` ports (1σ 300 m around the
  port: ships tens to hundreds of metres apart, the hard case for association), the others
  sailing straight legs between uniform random waypoints at 4–20 kn; ports and waypoints
  uniform in a square of side ``spread_km`` around (``lat0``, ``lon0``) in the tangent plane
  there (:mod:`.projection`);
- per ship a report interval ``median_interval`` × exp(0.5 N(0, 1)), each interval jittered by
  ±20 %, and per report a ``outage`` chance of losing the next three reports (a gap);
- defects, each a known count: ``n_duplicates`` repeated rows, ``n_corrupt`` positions moved
  to the other side of the globe (longitude + 180°), ``n_bad`` rows with an unparsable time.

:func:`write_csv` writes the rows in any :class:`~.reader.ColumnMap` (time as ISO, epoch ms,
epoch s or a ``strptime`` format; COG/SOG only if the mapping has them), shuffled like a real
export. ``python -m track_core.ais.synthetic OUT.csv [--seed S] [--preset NAME]`` writes the
default file (22,000-odd rows, the size of the issue's data set).
"""

from __future__ import annotations

import argparse
import csv
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from track_core.ais.projection import LocalTangentPlane
from track_core.ais.reader import KNOT, PRESETS, ColumnMap

T0 = 1.7e9  # 2023-11-14 22:13:20 UTC


@dataclass
class SyntheticAis:
    """Rows of a synthetic AIS file (unsorted, with the defects) and the defect counts."""

    t: np.ndarray          # epoch seconds
    mmsi: np.ndarray
    lat: np.ndarray
    lon: np.ndarray
    cog: np.ndarray
    sog: np.ndarray
    bad_time: np.ndarray   # bool: write this row's time as garbage
    defects: dict[str, int]

    def __len__(self) -> int:
        return self.t.size


def _ship(rng, duration, presence, port, half, median_interval, outage):
    """(t, east, north, cog, sog) of one ship's reports."""
    life = min(duration, max(3600.0, rng.exponential(presence * duration)))
    start = rng.uniform(0.0, duration - life)
    interval = median_interval * np.exp(0.5 * rng.standard_normal())
    n = int(life / interval) + 2
    dt = interval * rng.uniform(0.8, 1.2, n)
    lost = rng.random(n) < outage                          # lose the next three reports
    dt = dt + lost * 3 * interval
    t = start + np.concatenate([[0.0], np.cumsum(dt)])
    t = t[t <= start + life]
    if port is not None:
        p = port + 300.0 * rng.standard_normal(2)
        return t, np.full(t.size, p[0]), np.full(t.size, p[1]), np.full(t.size, np.nan), np.zeros(t.size)
    speed = rng.uniform(4.0, 20.0) * KNOT
    legs = int(life * speed / half) + 2                    # enough legs to cover the lifetime
    wp = rng.uniform(-half, half, (legs + 1, 2))
    seg = np.linalg.norm(np.diff(wp, axis=0), axis=1)
    tw = start + np.concatenate([[0.0], np.cumsum(seg / speed)])
    east, north = np.interp(t, tw, wp[:, 0]), np.interp(t, tw, wp[:, 1])
    k = np.clip(np.searchsorted(tw, t, side='right') - 1, 0, legs - 1)
    d = wp[k + 1] - wp[k]
    cog = np.degrees(np.arctan2(d[:, 0], d[:, 1])) % 360.0
    return t, east, north, cog, np.full(t.size, speed / KNOT)


def synthetic_ais(rng: np.random.Generator, *, n_ships: int = 256, duration: float = 4.5 * 86400.0,
                  spread_km: float = 200.0, median_interval: float = 720.0, presence: float = 0.2,
                  moored: float = 0.3, n_ports: int = 4, outage: float = 0.01, lat0: float = 56.0,
                  lon0: float = 11.0,
                  n_duplicates: int = 20, n_corrupt: int = 5, n_bad: int = 5) -> SyntheticAis:
    """The rows of a synthetic AIS file; see the module docstring."""
    half = 500.0 * spread_km
    ports = rng.uniform(-half, half, (max(n_ports, 1), 2))
    parts = [_ship(rng, duration, presence, ports[rng.integers(len(ports))] if rng.random() < moored else None,
                   half, median_interval, outage) for _ in range(n_ships)]          # one draw per ship
    mmsi = np.concatenate([np.full(p[0].size, 200_000_000 + i, np.int64) for i, p in enumerate(parts)])
    t, east, north, cog, sog = (np.concatenate([p[j] for p in parts]) for j in range(5))
    lat, lon = LocalTangentPlane(lat0, lon0).inverse(np.stack([east, north], 1))
    t = T0 + t
    m = t.size
    dup = rng.choice(m, n_duplicates, replace=False)
    t, mmsi, lat, lon, cog, sog = (np.concatenate([x, x[dup]]) for x in (t, mmsi, lat, lon, cog, sog))
    idx = rng.choice(np.setdiff1d(np.arange(m), dup), n_corrupt + n_bad, replace=False)  # not duplicated rows
    lon[idx[:n_corrupt]] = (lon[idx[:n_corrupt]] + 360.0) % 360.0 - 180.0
    bad_time = np.zeros(t.size, bool)
    bad_time[idx[n_corrupt:]] = True
    perm = rng.permutation(t.size)
    return SyntheticAis(t[perm], mmsi[perm], lat[perm], lon[perm], cog[perm], sog[perm], bad_time[perm],
                        {'duplicate': n_duplicates, 'corrupt position': n_corrupt, 'bad time': n_bad})


def _format_time(t: np.ndarray, fmt: str) -> list[str]:
    if fmt in {'epoch_ms', 'auto'}:
        return [f'{v:.0f}' for v in np.round(t * 1000.0)]
    if fmt == 'epoch_s':
        return [f'{v:.3f}' for v in t]
    pattern = '%Y-%m-%dT%H:%M:%S' if fmt == 'iso' else fmt
    return [datetime.fromtimestamp(float(v), UTC).strftime(pattern) for v in np.round(t)]


def write_csv(path: str | Path, data: SyntheticAis, columns: ColumnMap | str = 'solent') -> Path:
    """Write ``data`` with the column names, order and time format of ``columns`` (an extra column too)."""
    cols = ColumnMap.parse(columns)
    names = [cols.mmsi, cols.time, 'VesselName', cols.lon, cols.lat]   # lon before lat: order is by name
    values = [data.mmsi.astype(str), _format_time(data.t, cols.time_format), ['SYNTH'] * len(data),
              [f'{v:.7f}' for v in data.lon], [f'{v:.7f}' for v in data.lat]]
    if cols.cog:
        names.append(cols.cog)
        values.append(['360.0' if np.isnan(v) else f'{v:.1f}' for v in data.cog])
    if cols.sog:
        names.append(cols.sog)
        values.append([f'{v:.1f}' for v in data.sog])
    times = values[1]
    for k in np.flatnonzero(data.bad_time):
        times[k] = 'not-a-time'
    p = Path(path)
    with p.open('w', newline='') as fh:
        w = csv.writer(fh, delimiter=cols.delimiter)
        w.writerow(names)
        w.writerows(zip(*values, strict=True))
    return p


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog='python -m track_core.ais.synthetic', description=__doc__.split('\n')[0])
    ap.add_argument('out', type=Path)
    ap.add_argument('--seed', type=int, default=0)
    ap.add_argument('--preset', default='marinecadastre', choices=sorted(PRESETS))
    args = ap.parse_args(argv)
    data = synthetic_ais(np.random.default_rng(args.seed))
    write_csv(args.out, data, args.preset)
    print(f'{args.out}: {len(data)} rows, {np.unique(data.mmsi).size} ships, defects {data.defects}')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
