"""Reader of the Solent AIS reports (``../shared/data/ais_solent/*.csv``) with row validation.

Columns: ``Time`` (UTC, ``YYYY-MM-DD HH:MM:SS.fff``; a plain number is read as milliseconds
since the Unix epoch), ``MMSI``, ``Latitude_degrees``, ``Longitude_degrees``, ``COG_degrees``,
``SOG_knots``. A row that cannot be used is **skipped and counted** under one reason, the first
that applies:

- ``malformed row``: wrong number of columns;
- ``bad time``: the time is missing, unparsable or not finite;
- ``bad MMSI``: not a positive integer;
- ``bad position``: latitude/longitude missing, unparsable, NaN/inf, or outside [−90, 90] /
  [−180, 180] (this includes AIS's "not available" values 91 and 181);
- ``outside region``: more than ``max_distance_km`` (100 km) from the median position of the
  file: a corrupted position that is still a valid coordinate (the Solent file has one:
  longitude 54.83° for a ship moored at −1.092°);
- ``duplicate``: same MMSI and time as a row already kept;
- ``implied speed``: the jump from the ship's previous kept report needs more than
  ``max_speed_kn`` (100 kn).

COG and SOG are not needed for positions: their "not available" values (COG ≥ 360, SOG ≥
102.3) and unparsable entries become NaN and the row is kept. :attr:`AisData.skipped` holds
the counts, :meth:`AisData.describe` one line for reports. Kept rows are sorted by time.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from track_core.data import data_dir

COLUMNS = ('Time', 'MMSI', 'Latitude_degrees', 'Longitude_degrees', 'COG_degrees', 'SOG_knots')
DEFAULT_FILE = 'SolentAIS_20160112_130211.csv'
KNOT = 1852.0 / 3600.0  # m/s
REASONS = ('malformed row', 'bad time', 'bad MMSI', 'bad position', 'outside region', 'duplicate', 'implied speed')


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
        return (f'{self.rows} rows, {self.t.size} kept, {self.n_skipped} skipped ({why}); '
                f'{self.ships.size} ships, {self.t[-1] if self.t.size else 0.0:.0f} s from {self.start_utc}')


def _time(text: str) -> float:
    text = text.strip()
    try:
        v = float(text)  # epoch milliseconds
    except ValueError:
        v = None
    if v is not None:
        if not math.isfinite(v):
            raise ValueError(text)
        return v / 1000.0
    return datetime.fromisoformat(text).replace(tzinfo=UTC).timestamp()


def _angle(text: str, not_available: float) -> float:
    try:
        v = float(text)
    except ValueError:
        return math.nan
    return v if math.isfinite(v) and 0.0 <= v < not_available else math.nan


def _distance_m(lat1, lon1, lat2, lon2) -> np.ndarray:
    """Great-circle (haversine, R = 6371 km) distance; only used by the coarse gates."""
    p1, p2 = np.radians(lat1), np.radians(lat2)
    dp, dl = p2 - p1, np.radians(np.asarray(lon2) - np.asarray(lon1))
    h = np.sin(dp / 2) ** 2 + np.cos(p1) * np.cos(p2) * np.sin(dl / 2) ** 2
    return 2 * 6_371_000.0 * np.arcsin(np.sqrt(np.clip(h, 0.0, 1.0)))


def _distance1_m(lat1: float, lon1: float, lat2: float, lon2: float) -> float:
    """Scalar haversine (the sequential speed gate runs once per row)."""
    p1, p2 = math.radians(lat1), math.radians(lat2)
    h = math.sin((p2 - p1) / 2) ** 2 + math.cos(p1) * math.cos(p2) * math.sin(math.radians(lon2 - lon1) / 2) ** 2
    return 2 * 6_371_000.0 * math.asin(math.sqrt(min(max(h, 0.0), 1.0)))


def _parse_row(row: list[str]) -> tuple | str:
    """(t, mmsi, lat, lon, cog, sog) of one CSV row, or the reason it is skipped."""
    if len(row) != len(COLUMNS):
        return 'malformed row'
    try:
        t = _time(row[0])
    except (ValueError, OverflowError, OSError):
        return 'bad time'
    mmsi = int(row[1]) if row[1].strip().isdigit() else 0
    if mmsi <= 0:
        return 'bad MMSI'
    try:
        lat, lon = float(row[2]), float(row[3])
    except ValueError:
        return 'bad position'
    if not (math.isfinite(lat) and math.isfinite(lon) and -90.0 <= lat <= 90.0 and -180.0 <= lon <= 180.0):
        return 'bad position'
    return t, mmsi, lat, lon, _angle(row[4], 360.0), _angle(row[5], 102.3)


def _sequential_gate(t, mmsi, lat, lon, keep, skipped, max_speed_kn: float) -> None:
    """Mark duplicates and implied-speed jumps per ship (each report against the ship's last kept one)."""
    order = np.lexsort((t, mmsi)).tolist()  # by ship, then time (stable)
    tl, ml, lal, lol = t.tolist(), mmsi.tolist(), lat.tolist(), lon.tolist()
    last_ship, last_t, last_lat, last_lon = None, 0.0, 0.0, 0.0
    for i in order:  # sequential by nature
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


def read_ais(path: str | Path | None = None, *, max_distance_km: float = 100.0,
             max_speed_kn: float = 100.0) -> AisData:
    """Read and validate an AIS CSV file (default: the Solent file); see the module docstring."""
    p = Path(path) if path is not None else default_path()
    if not p.is_file():
        raise OSError(f'AIS file not found: {p} (set TRACK_DATA_DIR to the folder holding ais_solent/)')
    skipped = dict.fromkeys(REASONS, 0)
    parsed = []
    rows = 0
    with p.open(newline='') as fh:
        reader = csv.reader(fh)
        header = next(reader, None)
        if header is None or [h.strip() for h in header[:6]] != list(COLUMNS):
            raise ValueError(f'{p}: expected columns {", ".join(COLUMNS)}, got {header}')
        for row in reader:
            if not row or not any(c.strip() for c in row):
                continue
            rows += 1
            r = _parse_row(row)
            if isinstance(r, str):
                skipped[r] += 1
            else:
                parsed.append(r)
    cols = list(zip(*parsed, strict=True)) if parsed else [()] * 6
    t, lat, lon, cog, sog = (np.asarray(cols[k], float) for k in (0, 2, 3, 4, 5))
    mmsi = np.asarray(cols[1], np.int64)
    keep = np.ones(t.size, bool)
    if t.size:
        far = _distance_m(np.median(lat), np.median(lon), lat, lon) > max_distance_km * 1000.0
        skipped['outside region'] += int(far.sum())
        keep &= ~far
    _sequential_gate(t, mmsi, lat, lon, keep, skipped, max_speed_kn)
    idx = np.flatnonzero(keep)
    idx = idx[np.argsort(t[idx], kind='stable')]
    t0 = float(t[idx[0]]) if idx.size else 0.0
    return AisData(t[idx] - t0, mmsi[idx], lat[idx], lon[idx], cog[idx], sog[idx], t0, rows, skipped, p)
