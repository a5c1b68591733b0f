"""Live AIS: one decoded report → a map-frame position (and velocity) with its covariance; bounded ship state.

The AIS fields arrive already decoded (numbers, in the units of ITU-R M.1371: degrees, knots);
this module decides what they mean for a tracker, with no ROS and no NMEA in it.

Position. The position-accuracy flag (1: better than 10 m, typically DGNSS; 0: worse) is read as a
2σ radius: σ = ``SIGMA_HIGH`` = 5 m per axis for high accuracy, ``SIGMA_LOW`` = 15 m for low (2σ =
30 m, a generous bound for plain GNSS); circular, since the flag carries no direction.

Velocity. From speed over ground (SOG, knots, resolution 0.1 kn) and course over ground (COG,
degrees clockwise from true north, resolution 0.1°), turned to grid north by the datum
(``Datum.to_map_velocity``). Its covariance is an ellipse along the course: σ along =
``SIGMA_SOG`` = 0.25 m/s (½ kn: the GNSS speed noise, well above the 0.1 kn resolution), σ across =
speed · ``SIGMA_COG_DEG`` (2°: the course noise of a GNSS receiver at cruising speed). A ship
stopped (SOG < 0.1 kn) with no course gets a zero velocity with σ = ``SIGMA_SOG`` on both axes.

"Not available" values (ITU-R M.1371): SOG 102.3, COG 360, true heading 511, latitude 91,
longitude 181. A missing SOG or COG makes the velocity "not estimated" (``StateReport.v`` None);
a missing position makes the report useless for a tracker and it is refused, as is any field
outside its range (latitude beyond ±90, longitude beyond ±180, SOG above 102.3, COG above 360,
heading above 359 but 511, an MMSI outside 1..999 999 999). A refusal is a reason string.

Ship state (``ShipTable``). Per MMSI: the time of its last report (a report older than it is
refused: out of order), its name, type and call sign from static data (types 5, 19, 24). The
table is bounded: at most ``max_ships`` MMSIs, the least recently heard one forgotten first, and
a ship silent for ``forget_after`` seconds forgotten at the next ``expire``. A busy port hears a
few thousand MMSIs a day; the default bound (10 000) holds them with room.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from dataclasses import dataclass, field

import numpy as np

KNOT = 1852.0 / 3600.0           # m/s per knot
SIGMA_HIGH = 5.0                 # 1σ per axis of a high-accuracy fix (flag 1: better than 10 m = 2σ) [m]
SIGMA_LOW = 15.0                 # 1σ per axis of a low-accuracy fix (flag 0: worse than 10 m; 2σ = 30 m) [m]
SIGMA_SOG = 0.25                 # 1σ of the speed over ground [m/s]
SIGMA_COG_DEG = 2.0              # 1σ of the course over ground [deg]
STOPPED_KN = 0.1                 # below this SOG a ship without a course is read as stopped [kn]

SOG_NA, COG_NA, HEADING_NA, LAT_NA, LON_NA = 102.3, 360.0, 511, 91.0, 181.0
POSITION_TYPES = frozenset({1, 2, 3, 18, 19})      # class A (1-3) and class B (18, 19) position reports
STATIC_TYPES = frozenset({5, 19, 24})              # static and voyage data (class A 5, class B 19 and 24)
MMSI_MAX = 999_999_999


@dataclass(frozen=True)
class PositionFields:
    """The fields of a position report as decoded (ITU-R M.1371 units), before any interpretation."""

    msg_type: int
    mmsi: int
    lat: float
    lon: float
    sog: float            # knots; 102.3 not available
    cog: float            # degrees from true north; 360 not available
    heading: float        # degrees; 511 not available
    accuracy: bool        # position accuracy flag: True = high (better than 10 m)


@dataclass(frozen=True)
class StateReport:
    """One report in the map: position z (2,) and its covariance R (2, 2); velocity v (2,) and Pv, or None."""

    mmsi: int
    t: float
    z: np.ndarray
    R: np.ndarray
    v: np.ndarray | None
    Pv: np.ndarray | None
    heading_deg: float | None    # true heading, when available (kept for display; not in the CV state)
    msg_type: int


def _num(x) -> float:
    try:
        return float(x)
    except (TypeError, ValueError):
        return math.nan


def position_problem(f: PositionFields) -> str | None:  # noqa: PLR0911 - one reason per field
    """Why the report cannot place a ship (one line, the field first), else None."""
    if f.msg_type not in POSITION_TYPES:
        return f'msg_type: {f.msg_type} is not a position report (1, 2, 3, 18, 19)'
    if not 1 <= f.mmsi <= MMSI_MAX:
        return f'mmsi: {f.mmsi} is outside 1..{MMSI_MAX}'
    lat, lon, sog, cog, hdg = (_num(v) for v in (f.lat, f.lon, f.sog, f.cog, f.heading))
    if lat == LAT_NA or lon == LON_NA:
        return f'position: not available (lat {lat:g}, lon {lon:g}) from MMSI {f.mmsi}'
    if not (math.isfinite(lat) and -90.0 <= lat <= 90.0):
        return f'lat: {lat!r} is outside [-90, 90] (MMSI {f.mmsi})'
    if not (math.isfinite(lon) and -180.0 <= lon <= 180.0):
        return f'lon: {lon!r} is outside [-180, 180] (MMSI {f.mmsi})'
    if not (math.isfinite(sog) and 0.0 <= sog <= SOG_NA + 1e-9):
        return f'sog: {sog!r} kn is outside [0, 102.3] (MMSI {f.mmsi})'
    if not (math.isfinite(cog) and 0.0 <= cog <= COG_NA + 1e-9):
        return f'cog: {cog!r}° is outside [0, 360] (MMSI {f.mmsi})'
    if not (math.isfinite(hdg) and (0.0 <= hdg < 360.0 or hdg == HEADING_NA)):
        return f'heading: {hdg!r}° is outside [0, 359] and not 511 (MMSI {f.mmsi})'
    return None


def sog_available(sog: float) -> bool:
    return abs(sog - SOG_NA) > 0.05


def cog_available(cog: float) -> bool:
    return abs(cog - COG_NA) > 0.05


def position_sigma(high_accuracy: bool) -> float:
    return SIGMA_HIGH if high_accuracy else SIGMA_LOW


def state_report(f: PositionFields, t: float, datum) -> StateReport:
    """A valid report (``position_problem`` is None) → its map-frame state and covariances (module docstring)."""
    z = datum.forward(f.lat, f.lon)
    s = position_sigma(bool(f.accuracy))
    R = np.eye(2) * s * s
    v = Pv = None
    sog, cog = float(f.sog), float(f.cog)
    if sog_available(sog) and cog_available(cog):
        speed = sog * KNOT
        v = datum.to_map_velocity(f.lat, f.lon, speed, cog)
        b = math.atan2(v[0], v[1])                       # grid bearing of the course
        along = np.array([math.sin(b), math.cos(b)])
        across = np.array([math.cos(b), -math.sin(b)])
        s_across = max(speed * math.radians(SIGMA_COG_DEG), 1e-3)
        Pv = SIGMA_SOG**2 * np.outer(along, along) + s_across**2 * np.outer(across, across)
    elif sog_available(sog) and sog < STOPPED_KN:
        v, Pv = np.zeros(2), np.eye(2) * SIGMA_SOG**2
    hdg = float(f.heading)
    return StateReport(int(f.mmsi), float(t), z, R, v, Pv, None if hdg == HEADING_NA else hdg, int(f.msg_type))


@dataclass
class Ship:
    """What is known of one MMSI: the last report's time, static data (empty until heard)."""

    mmsi: int
    last_t: float = -math.inf
    last_heard: float = -math.inf       # the table's clock (arrival), for forgetting
    reports: int = 0
    name: str = ''
    ship_type: int = 0                  # 0: not available (ITU-R M.1371 table 53)
    callsign: str = ''


@dataclass
class ShipTable:
    """Per-MMSI state with a bound on its size (module docstring)."""

    max_ships: int = 10_000
    forget_after: float = 3600.0
    ships: OrderedDict = field(default_factory=OrderedDict)
    forgotten: int = 0

    def _touch(self, mmsi: int, now: float) -> Ship:
        ship = self.ships.get(mmsi)
        if ship is None:
            ship = self.ships[mmsi] = Ship(mmsi)
            while len(self.ships) > self.max_ships:
                self.ships.popitem(last=False)
                self.forgotten += 1
        else:
            self.ships.move_to_end(mmsi)
        ship.last_heard = now
        return ship

    def order_problem(self, mmsi: int, t: float) -> str | None:
        ship = self.ships.get(mmsi)
        if ship is not None and t < ship.last_t:
            return f'stamp: report of MMSI {mmsi} at {t:.3f} s is older than its last one ({ship.last_t:.3f} s)'
        return None

    def position(self, mmsi: int, t: float, now: float) -> Ship:
        ship = self._touch(mmsi, now)
        ship.last_t = max(ship.last_t, t)
        ship.reports += 1
        return ship

    def static(self, mmsi: int, now: float, name: str | None = None, ship_type: int | None = None,
               callsign: str | None = None) -> tuple[Ship, bool]:
        """Static data of an MMSI; returns the ship and whether anything changed."""
        ship = self._touch(mmsi, now)
        before = (ship.name, ship.ship_type, ship.callsign)
        if name:
            ship.name = name
        if ship_type:
            ship.ship_type = int(ship_type)
        if callsign:
            ship.callsign = callsign
        return ship, before != (ship.name, ship.ship_type, ship.callsign)

    def expire(self, now: float) -> int:
        """Forget the ships silent for ``forget_after`` (oldest first); return how many."""
        n = 0
        while self.ships:
            mmsi, ship = next(iter(self.ships.items()))
            if now - ship.last_heard <= self.forget_after:
                break
            del self.ships[mmsi]
            n += 1
        self.forgotten += n
        return n

    def __len__(self) -> int:
        return len(self.ships)


@dataclass
class FeedWatch:
    """Whether a feed has stopped: silent for ``silence`` seconds after its last sentence (or its start)."""

    silence: float = 30.0
    last: float | None = None
    quiet: bool = False

    def heard(self, now: float) -> bool:
        """A sentence arrived; True when the feed was reported silent and is back."""
        self.last = now
        back, self.quiet = self.quiet, False
        return back

    def check(self, now: float, started: float) -> float | None:
        """The silent time when the feed has just been found silent (once per silence), else None."""
        since = now - (self.last if self.last is not None else started)
        if not self.quiet and since >= self.silence:
            self.quiet = True
            return since
        return None
