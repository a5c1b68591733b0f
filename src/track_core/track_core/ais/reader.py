"""Reader of AIS CSV exports with row validation.

Default: the Solent file ``ais_solent/*.csv`` of the data folder (``track_core.data``).

Columns (:class:`ColumnMap`) are found by header name: ``time``, ``mmsi``, ``lat``, ``lon``,
optional ``cog`` [degrees from north] and ``sog`` [knots], ``time_format``, ``delimiter``; given as
a :class:`ColumnMap`, a preset (``solent``, ``marinecadastre``, ``dma``) or a text
``"time=BaseDateTime;lat=LAT;lon=LON;cog=;sog="`` (empty = absent); ``columns=None`` detects the
preset from the header. ``time_format``: ``auto`` (a number ≥ 10¹¹ is epoch ms, below epoch s, else
ISO 8601), ``iso``, ``epoch_ms``, ``epoch_s`` or a ``strptime`` format; times without a zone are
UTC. Without ``cog``/``sog`` columns they are computed from the positions (``derived['cog_sog']``);
their "not available" codes (COG ≥ 360, SOG ≥ 102.3) become NaN.

Rows that cannot be used are skipped and counted under the first reason that applies: ``malformed
row``, ``bad time``, ``bad MMSI``, ``no position`` (empty, or 91 / 181), ``bad position``, ``outside
region`` (further from the median position than the region radius; ``max_distance_km='auto'`` ends
the region at the first jump of the sorted distances to more than ``REGION_FACTOR`` (3) × the one
before, beyond ``REGION_FLOOR_KM`` (10 km), leaving at most ``REGION_TAIL`` (1 %) of the rows; a
number fixes it, ``None`` turns it off), ``duplicate`` (same MMSI, time and position; same time at
another position is kept and spread by :func:`refine_same_time`), ``implied speed`` (over
``max_speed_kn``, 100 kn, from the previous kept report). A rule dropping more than
``warn_fraction`` (2 %) of the rows logs a warning naming its parameter (:attr:`AisData.warnings`);
:attr:`AisData.skipped` holds the counts, :attr:`AisData.derived` the derived defaults,
:meth:`AisData.describe` one line. Rows sorted by time. Presets and reasons in full: docs/MODULES.md,
"The AIS CSV reader in full".
"""

from __future__ import annotations

import csv
import logging
import math
from dataclasses import dataclass, field, fields, replace
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from track_core.data import data_dir

log = logging.getLogger(__name__)

COLUMNS = ('Time', 'MMSI', 'Latitude_degrees', 'Longitude_degrees', 'COG_degrees', 'SOG_knots')
DEFAULT_FILE = 'SolentAIS_20160112_130211.csv'
KNOT = 1852.0 / 3600.0  # m/s
REASONS = ('malformed row', 'bad time', 'bad MMSI', 'no position', 'bad position', 'outside region', 'duplicate',
           'implied speed')
REGION_FACTOR = 3.0
REGION_TAIL = 0.01
REGION_FLOOR_KM = 10.0
EARTH_R = 6_371_000.0
CONTROLLED_BY = {
    'malformed row': 'the column mapping (columns=..., delimiter)',
    'bad time': 'the column mapping (time, time_format)',
    'bad MMSI': 'the column mapping (mmsi)',
    'no position': 'none (messages that carry no position, e.g. AIS static and voyage data, types 5 and 24)',
    'bad position': 'the column mapping (lat, lon)',
    'outside region': "max_distance_km ('auto': derived, None: off)",
    'duplicate': 'none (the same ship, time and position twice)',
    'implied speed': 'max_speed_kn',
}
TIME_FORMATS = ('auto', 'iso', 'epoch_ms', 'epoch_s')
DELIMITERS = {'comma': ',', 'semicolon': ';', 'tab': '\t', 'space': ' ', 'pipe': '|'}


@dataclass(frozen=True)
class ColumnMap:
    """Header names of the columns used (``None``: absent) and the time format; see the module docstring."""

    time: str = 'Time'
    mmsi: str = 'MMSI'
    lat: str = 'Latitude_degrees'
    lon: str = 'Longitude_degrees'
    cog: str | None = 'COG_degrees'
    sog: str | None = 'SOG_knots'
    time_format: str = 'auto'
    delimiter: str = ','

    @classmethod
    def parse(cls, spec: str | ColumnMap | None) -> ColumnMap | None:
        """A preset name, ``"key=value;..."`` text, a ColumnMap, or None/'' (detect from the header)."""
        if spec is None or isinstance(spec, ColumnMap):
            return spec
        spec = spec.strip()
        if not spec:
            return None
        if spec in PRESETS:
            return PRESETS[spec]
        names = {f.name for f in fields(cls)}
        kw = {}
        for item in spec.split(';'):
            key, sep, value = item.partition('=')
            key = key.strip()
            if not sep or key not in names:
                raise ValueError(f'column mapping {spec!r}: {item!r} is not key=value with key one of '
                                 f'{", ".join(sorted(names))} (or give a preset: {", ".join(PRESETS)})')
            value = value.strip()
            if key == 'delimiter':
                value = DELIMITERS.get(value, value)
                if len(value) != 1:
                    raise ValueError(f'column mapping {spec!r}: delimiter must be one character or one of '
                                     f'{", ".join(DELIMITERS)}, got {value!r}')
            if key in ('time', 'mmsi', 'lat', 'lon', 'time_format') and not value:
                raise ValueError(f'column mapping {spec!r}: {key} cannot be empty')
            kw[key] = value or None
        return replace(cls(), **kw)

    def required(self) -> tuple[str, ...]:
        return (self.time, self.mmsi, self.lat, self.lon)


PRESETS = {
    'solent': ColumnMap(),
    'marinecadastre': ColumnMap('BaseDateTime', 'MMSI', 'LAT', 'LON', 'COG', 'SOG', 'iso'),
    'dma': ColumnMap('# Timestamp', 'MMSI', 'Latitude', 'Longitude', 'COG', 'SOG', '%d/%m/%Y %H:%M:%S'),
}


def default_path() -> Path:
    """The Solent file under ``track_core.data.data_dir('ais_solent')``."""
    return data_dir('ais_solent') / DEFAULT_FILE


@dataclass
class AisData:
    """Valid AIS reports, time-sorted. ``t`` is seconds since ``t0`` (UTC epoch seconds of the first)."""

    t: np.ndarray
    mmsi: np.ndarray
    lat: np.ndarray
    lon: np.ndarray
    cog: np.ndarray
    sog: np.ndarray
    t0: float
    rows: int
    skipped: dict[str, int] = field(default_factory=dict)
    path: Path | None = None
    derived: dict[str, object] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)

    @property
    def n_skipped(self) -> int:
        return sum(self.skipped.values())

    @property
    def ships(self) -> np.ndarray:
        return np.unique(self.mmsi)

    @property
    def start_utc(self) -> str:
        return datetime.fromtimestamp(self.t0, UTC).strftime('%Y-%m-%d %H:%M:%S UTC')

    def centroid(self) -> tuple[float, float]:
        """Median latitude and longitude of the kept reports (the projection origin)."""
        return float(np.median(self.lat)), float(np.median(self.lon))

    def describe(self) -> str:
        why = ', '.join(f'{k}: {v}' for k, v in self.skipped.items() if v) or 'none'
        r = self.derived.get('max_distance_km')
        region = 'region gate off' if r is None else f'region radius {r:.1f} km'
        if self.derived.get('region_rule') == 'auto':
            region += ' (derived)'
        refined = self.derived.get('time_refined') or 0
        if refined:
            why += (f'; {refined} same-time reports of a ship at another position kept, their times spread over '
                    f'{self.derived.get("time_resolution_s"):g} s')
        return (f'{self.rows} rows, {self.t.size} kept, {self.n_skipped} skipped ({why}); '
                f'{self.ships.size} ships, {self.t[-1] if self.t.size else 0.0:.0f} s from {self.start_utc}; '
                f'{region}; COG/SOG {self.derived.get("cog_sog", "from the file")}')


def _time(text: str, fmt: str) -> float:
    text = text.strip()
    if fmt in ('auto', 'epoch_ms', 'epoch_s'):
        try:
            v = float(text)
        except ValueError:
            if fmt != 'auto':
                raise
            v = None
        if v is not None:
            if not math.isfinite(v):
                raise ValueError(text)
            ms = fmt == 'epoch_ms' or (fmt == 'auto' and abs(v) >= 1e11)
            return v / 1000.0 if ms else v
        fmt = 'iso'
    d = datetime.fromisoformat(text) if fmt == 'iso' else datetime.strptime(text, fmt)
    return (d.replace(tzinfo=UTC) if d.tzinfo is None else d).timestamp()


def _angle(text: str, not_available: float) -> float:
    try:
        v = float(text)
    except ValueError:
        return math.nan
    return v if math.isfinite(v) and 0.0 <= v < not_available else math.nan


def _distance_m(lat1, lon1, lat2, lon2) -> np.ndarray:
    """Great-circle (haversine, R = 6371 km) distance; only used by the coarse gates and COG/SOG."""
    p1, p2 = np.radians(lat1), np.radians(lat2)
    dp, dl = p2 - p1, np.radians(np.asarray(lon2) - np.asarray(lon1))
    h = np.sin(dp / 2) ** 2 + np.cos(p1) * np.cos(p2) * np.sin(dl / 2) ** 2
    return 2 * EARTH_R * np.arcsin(np.sqrt(np.clip(h, 0.0, 1.0)))


def _distance1_m(lat1: float, lon1: float, lat2: float, lon2: float) -> float:
    """Scalar haversine (the sequential speed gate runs once per row)."""
    p1, p2 = math.radians(lat1), math.radians(lat2)
    h = math.sin((p2 - p1) / 2) ** 2 + math.cos(p1) * math.cos(p2) * math.sin(math.radians(lon2 - lon1) / 2) ** 2
    return 2 * EARTH_R * math.asin(math.sqrt(min(max(h, 0.0), 1.0)))


class _RowParser:
    """(t, mmsi, lat, lon, cog, sog) of one CSV row by header position, or the reason it is skipped."""

    def __init__(self, header: list[str], cols: ColumnMap, p: Path) -> None:
        names = [h.strip() for h in header]
        missing = [c for c in cols.required() if c not in names]
        if missing:
            raise ValueError(f'{p}: expected columns {", ".join(cols.required())} (column mapping), missing '
                             f'{", ".join(missing)}; header: {header}')
        self.n = len(names)
        self.it, self.im, self.ila, self.ilo = (names.index(c) for c in cols.required())
        self.ic = names.index(cols.cog) if cols.cog in names else None
        self.iv = names.index(cols.sog) if cols.sog in names else None
        self.fmt = cols.time_format

    def __call__(self, row: list[str]) -> tuple | str:
        if len(row) != self.n:
            return 'malformed row'
        try:
            t = _time(row[self.it], self.fmt)
        except (ValueError, OverflowError, OSError):
            return 'bad time'
        m = row[self.im].strip()
        mmsi = int(m) if m.isdigit() else 0
        if mmsi <= 0:
            return 'bad MMSI'
        pos = _position(row[self.ila], row[self.ilo])
        if isinstance(pos, str):
            return pos
        lat, lon = pos
        cog = _angle(row[self.ic], 360.0) if self.ic is not None else math.nan
        sog = _angle(row[self.iv], 102.3) if self.iv is not None else math.nan
        return t, mmsi, lat, lon, cog, sog


def _position(la: str, lo: str) -> tuple[float, float] | str:
    """(lat, lon) of a row, or why it has none ('no position': empty or AIS "not available" 91/181;
    'bad position': unparsable or outside the globe)."""
    la, lo = la.strip(), lo.strip()
    if not la or not lo:
        return 'no position'
    try:
        lat, lon = float(la), float(lo)
    except ValueError:
        return 'bad position'
    if lat == 91.0 or lon == 181.0:  # AIS "not available"
        return 'no position'
    if not (math.isfinite(lat) and math.isfinite(lon) and -90.0 <= lat <= 90.0 and -180.0 <= lon <= 180.0):
        return 'bad position'
    return lat, lon


def _detect(header: list[str], p: Path) -> ColumnMap:
    names = {h.strip() for h in header}
    for cols in PRESETS.values():
        if set(cols.required()) <= names:
            return cols
    raise ValueError(f'{p}: header {header} matches no preset ({", ".join(PRESETS)}); give a column mapping '
                     f'"time=...;mmsi=...;lat=...;lon=...[;cog=...;sog=...;time_format=...]"')


def time_resolution(t: np.ndarray) -> float:
    """The coarsest of 60 s and 1 s that every time [s] is a multiple of (0.0: finer stamps)."""
    for res in (60.0, 1.0):
        if t.size and np.all(np.abs(t - res * np.round(t / res)) < 1e-6):
            return res
    return 0.0


def refine_same_time(t, mmsi, lat, lon, keep, skipped) -> tuple[int, float]:
    """Reports of one ship at one time (stamps truncated to the minute or second), among the kept rows.

    The same position again is a ``duplicate`` (dropped). Different positions are different
    reports of a ship that moved within the stamp's resolution: they are kept, ordered along the
    track (by their distance from the ship's report before them, or else decreasing distance to
    the one after them, or else in file order) and their times spread evenly over the resolution
    (``time_resolution``; 1 s for finer stamps): the k-th of n gets t + k·res/n. Changes ``t`` and
    ``keep`` in place; returns (reports whose time was refined, the resolution used).
    """
    idx = np.flatnonzero(keep)
    o = idx[np.lexsort((t[idx], mmsi[idx]))]
    same = (mmsi[o][1:] == mmsi[o][:-1]) & (t[o][1:] == t[o][:-1])
    if not same.any():
        return 0, 0.0
    res = time_resolution(t[idx]) or 1.0
    starts = np.flatnonzero(np.r_[True, ~same])
    ends = np.r_[starts[1:], o.size]
    refined = 0
    for a, b in zip(starts[ends - starts > 1].tolist(), ends[ends - starts > 1].tolist(), strict=True):
        g = o[a:b]  # one ship, one time (a group: a loop over the data's collisions, not over rows)
        _, first = np.unique(np.c_[lat[g], lon[g]], axis=0, return_index=True)
        dup = np.setdiff1d(np.arange(g.size), first)
        keep[g[dup]] = False
        skipped['duplicate'] += int(dup.size)
        g = g[np.sort(first)]
        if g.size < 2:
            continue
        ship = mmsi[g[0]]
        if a > 0 and mmsi[o[a - 1]] == ship:
            key = _distance_m(lat[o[a - 1]], lon[o[a - 1]], lat[g], lon[g])
        elif b < o.size and mmsi[o[b]] == ship:
            key = -_distance_m(lat[o[b]], lon[o[b]], lat[g], lon[g])
        else:
            key = np.arange(g.size, dtype=float)
        g = g[np.argsort(key, kind='stable')]
        t[g] = t[g[0]] + res / g.size * np.arange(g.size)
        refined += int(g.size - 1)
    return refined, res


def _sequential_gate(t, mmsi, lat, lon, keep, skipped, max_speed_kn: float) -> None:
    """Mark duplicates and implied-speed jumps per ship (each report against the ship's last kept one)."""
    order = np.lexsort((t, mmsi)).tolist()  # by ship, then time (stable)
    tl, ml, lal, lol = t.tolist(), mmsi.tolist(), lat.tolist(), lon.tolist()
    last_ship, last_t, last_lat, last_lon = None, 0.0, 0.0, 0.0
    for i in order:  # sequential by nature: each report is compared with the last one *kept*
        if not keep[i]:
            continue
        if ml[i] == last_ship:
            if tl[i] == last_t:
                skipped['duplicate'] += 1
                keep[i] = False
                continue
            if _distance1_m(last_lat, last_lon, lal[i], lol[i]) / (tl[i] - last_t) > max_speed_kn * KNOT:
                skipped['implied speed'] += 1
                keep[i] = False
                continue
        last_ship, last_t, last_lat, last_lon = ml[i], tl[i], lal[i], lol[i]


def region_radius_km(lat: np.ndarray, lon: np.ndarray) -> float:
    """The derived region radius [km] (module docstring): the farthest distance before the first stray jump."""
    d = np.sort(_distance_m(np.median(lat), np.median(lon), lat, lon)) / 1000.0
    n = d.size
    tail = n - 1 - np.arange(n - 1)                         # rows beyond a jump after sorted row j
    jump = (d[1:] > REGION_FACTOR * np.maximum(d[:-1], REGION_FLOOR_KM)) & (tail <= max(1.0, REGION_TAIL * n))
    j = np.flatnonzero(jump)
    return float(d[j[0]]) if j.size else float(d[-1])


def course_speed(t, mmsi, lat, lon) -> tuple[np.ndarray, np.ndarray]:
    """COG [deg from north] and SOG [kn] from positions: each report to the ship's next (last: from the previous)."""
    n = t.size
    cog, sog = np.full(n, np.nan), np.full(n, np.nan)
    if n < 2:
        return cog, sog
    o = np.lexsort((t, mmsi))
    same = mmsi[o][1:] == mmsi[o][:-1]                 # segment k joins o[k] and o[k + 1]
    la, lo, tt = lat[o], lon[o], t[o]
    dy = np.radians(la[1:] - la[:-1]) * EARTH_R
    dl = (lo[1:] - lo[:-1] + 180.0) % 360.0 - 180.0
    dx = np.radians(dl) * EARTH_R * np.cos(np.radians(0.5 * (la[1:] + la[:-1])))
    c = np.degrees(np.arctan2(dx, dy)) % 360.0
    v = np.hypot(dx, dy) / np.maximum(tt[1:] - tt[:-1], 1e-9) / KNOT
    seg = np.full(n, -1)                                # segment used by each sorted report
    seg[:-1][same] = np.flatnonzero(same)               # forward segment
    back = np.zeros(n, bool)
    back[1:] = same
    last = (seg < 0) & back                             # no forward segment but a backward one
    seg[last] = np.flatnonzero(last) - 1
    ok = seg >= 0
    cog[o[ok]], sog[o[ok]] = c[seg[ok]], v[seg[ok]]
    return cog, sog


def _read_rows(p: Path, cols: ColumnMap | None, skipped: dict[str, int]):
    """(rows, parsed tuples, the row parser, the column mapping used); skipped rows are counted."""
    parsed = []
    rows = 0
    with p.open(newline='', encoding='utf-8-sig') as fh:  # a byte-order mark (common in exports) is not a name
        reader = csv.reader(fh, delimiter=cols.delimiter if cols is not None else ',')
        header = next(reader, None)
        if header is None:
            raise ValueError(f'{p}: empty file, expected a header line')
        cols = cols if cols is not None else _detect(header, p)
        parse = _RowParser(header, cols, p)
        for row in reader:
            if not row or not any(c.strip() for c in row):
                continue
            rows += 1
            r = parse(row)
            if isinstance(r, str):
                skipped[r] += 1
            else:
                parsed.append(r)
    return rows, parsed, parse, cols


def _warn_discards(data: AisData, warn_fraction: float) -> None:
    """Loud discards: one warning per rule that dropped more than ``warn_fraction`` of the rows."""
    for reason, n in data.skipped.items():
        if data.rows and n > warn_fraction * data.rows:
            name = data.path.name if data.path is not None else 'AIS data'
            msg = (f'{name}: rule "{reason}" dropped {n} of {data.rows} rows ({100 * n / data.rows:.1f} %); '
                   f'controlled by {CONTROLLED_BY[reason]}')
            data.warnings.append(msg)
            log.warning(msg)


def read_ais(path: str | Path | None = None, *, columns: str | ColumnMap | None = None,
             max_distance_km: float | str | None = 'auto', max_speed_kn: float = 100.0,
             warn_fraction: float = 0.02) -> AisData:
    """Read and validate an AIS CSV file (default: the Solent file); see the module docstring."""
    p = Path(path) if path is not None else default_path()
    if not p.is_file():
        raise OSError(f'AIS file not found: {p} (set TRACK_DATA_DIR to the folder holding ais_solent/)')
    if not (max_distance_km is None or max_distance_km == 'auto' or float(max_distance_km) > 0):
        raise ValueError(f"max_distance_km must be 'auto', None or > 0, got {max_distance_km!r}")
    skipped = dict.fromkeys(REASONS, 0)
    rows, parsed, parse, cols = _read_rows(p, ColumnMap.parse(columns), skipped)
    cols_ = list(zip(*parsed, strict=True)) if parsed else [()] * 6
    t, lat, lon, cog, sog = (np.asarray(cols_[k], float) for k in (0, 2, 3, 4, 5))
    mmsi = np.asarray(cols_[1], np.int64)
    keep = np.ones(t.size, bool)
    radius = None
    if t.size and max_distance_km is not None:
        radius = region_radius_km(lat, lon) if max_distance_km == 'auto' else float(max_distance_km)
        far = _distance_m(np.median(lat), np.median(lon), lat, lon) > radius * 1000.0
        skipped['outside region'] += int(far.sum())
        keep &= ~far
    refined, res = refine_same_time(t, mmsi, lat, lon, keep, skipped)
    _sequential_gate(t, mmsi, lat, lon, keep, skipped, max_speed_kn)
    idx = np.flatnonzero(keep)
    idx = idx[np.argsort(t[idx], kind='stable')]
    t0 = float(t[idx[0]]) if idx.size else 0.0
    derived = {'columns': {f.name: getattr(cols, f.name) for f in fields(cols)},
               'region_rule': 'auto' if max_distance_km == 'auto' else ('off' if max_distance_km is None else 'fixed'),
               'max_distance_km': radius, 'cog_sog': 'from the file', 'time_refined': refined,
               'time_resolution_s': res}
    data = AisData(t[idx] - t0, mmsi[idx], lat[idx], lon[idx], cog[idx], sog[idx], t0, rows, skipped, p, derived)
    if parse.ic is None or parse.iv is None:
        c, v = course_speed(data.t, data.mmsi, data.lat, data.lon)
        if parse.ic is None:
            data.cog = c
        if parse.iv is None:
            data.sog = v
        data.derived['cog_sog'] = 'computed from positions' if parse.ic is None and parse.iv is None else \
            f'{"COG" if parse.ic is None else "SOG"} computed from positions'
    _warn_discards(data, warn_fraction)
    return data
