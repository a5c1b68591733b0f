"""One datum per run: WGS-84 latitude/longitude ⇄ ``map`` east/north metres through PROJ (pyproj).

The ``map`` frame is the transverse Mercator projection of WGS-84 about the origin (φ0, λ0), scale 1
on the central meridian, no false easting/northing (``+proj=tmerc +lat_0=φ0 +lon_0=λ0 +k_0=1 +x_0=0
+y_0=0 +ellps=WGS84``): x east, y north (REP-103), the origin at (0, 0). Conformal; point scale k ≈
1 + x²/(2R²) (10⁻³ at 285 km, ``projection.MAX_SCALE_ERROR``). Grid north turns from true north by
the meridian convergence γ ≈ Δλ·sin φ: ``Datum.to_map_velocity`` rotates a course over ground by it,
``Datum.to_map_covariance`` an east/north covariance (a NavSatFix's). ``Datum.forward`` /
``inverse`` convert positions; ``Datum.earth_pose`` is ``map`` in REP-105's ``earth`` (ECEF,
EPSG:4978: the origin with east, north, up axes, as ``navsat_transform``'s ``utm`` → ``map``), for
placing the map on a globe only.

``RunDatum``: each node's view of the run's datum. The first datum heard on the latched topic, or
this node's own (``origin`` parameter or first fix), is the run's; an earlier-published datum wins
(earlier stamp, then smaller latitude, then longitude). A node whose own datum lost has a
``conflict`` and refuses its input naming both; after ``SETTLE_S`` any different datum is refused.
Why PROJ and one origin, and the error figures: docs/MODULES.md, "One datum per run".
"""

from __future__ import annotations

import math

import numpy as np
from pyproj import CRS, Geod, Transformer
from pyproj.exceptions import ProjError
from scipy.spatial.transform import Rotation

_GEOD = Geod(ellps='WGS84')
NORTH_STEP_DEG = 1e-5   # the step north that measures the meridian convergence [deg]
DATUM_MATCH_M = 0.01   # two origins closer than this on the ground are the same datum [m]
SETTLE_S = 2.0         # a node's datum is the run's this long after it fixed or took it [s]: DDS delivers a
                       # latched datum in well under a second, so nodes started together have settled by then


class Datum:
    """The ``map`` frame's place on the earth: transverse Mercator about (lat0, lon0) on WGS-84."""

    def __init__(self, lat0: float, lon0: float) -> None:
        if not (math.isfinite(lat0) and math.isfinite(lon0) and -90.0 < lat0 < 90.0 and -180.0 <= lon0 <= 180.0):
            raise ValueError(f'datum origin must be a finite latitude in (-90, 90) and longitude in [-180, 180], '
                             f'got ({lat0}, {lon0})')
        self.lat0, self.lon0 = float(lat0), float(lon0)
        self.crs = CRS.from_proj4(f'+proj=tmerc +lat_0={self.lat0!r} +lon_0={self.lon0!r} +k_0=1 +x_0=0 +y_0=0 '
                                  '+ellps=WGS84 +units=m +no_defs')
        try:
            self._fwd = Transformer.from_crs('EPSG:4326', self.crs, always_xy=True)
        except ProjError as exc:  # pragma: no cover - a PROJ install without its database
            raise ValueError(f'datum ({lat0}, {lon0}): PROJ refused the projection: {exc}') from None

    def __repr__(self) -> str:
        return f'Datum({self.lat0!r}, {self.lon0!r})'

    def describe(self) -> str:
        return f'({self.lat0:.7f}°, {self.lon0:.7f}°)'

    def forward(self, lat_deg, lon_deg) -> np.ndarray:
        """(…,) latitudes/longitudes [deg] → (…, 2) map east/north [m]."""
        x, y = self._fwd.transform(np.asarray(lon_deg, float), np.asarray(lat_deg, float))
        return np.stack([np.asarray(x, float), np.asarray(y, float)], -1)

    def inverse(self, en) -> tuple[np.ndarray, np.ndarray]:
        """(…, 2) map east/north [m] → (lat, lon) [deg]."""
        en = np.asarray(en, float)
        lon, lat = self._fwd.transform(en[..., 0], en[..., 1], direction='INVERSE')
        return np.asarray(lat, float), np.asarray(lon, float)

    def convergence(self, lat_deg, lon_deg) -> np.ndarray:
        """Meridian convergence γ [rad] at the points: the angle from true north to grid north (+y).

        Read off the projection itself: the grid bearing of a step of 10⁻⁵° (about 1 m) north.
        """
        lat, lon = np.asarray(lat_deg, float), np.asarray(lon_deg, float)
        step = np.where(lat > 89.0, -NORTH_STEP_DEG, NORTH_STEP_DEG)
        p = self.forward(np.stack([lat, lat + step]), np.stack([lon, lon]))
        d = (p[1] - p[0]) * np.sign(step)[..., None]
        return -np.arctan2(d[..., 0], d[..., 1])

    def to_map_velocity(self, lat_deg, lon_deg, speed, course_deg) -> np.ndarray:
        """A speed [m/s] on a course over ground [deg clockwise from true north] → (…, 2) map (vx, vy).

        The course is turned into grid bearing (course − γ) first: at 30 km from the origin
        this is a few hundredths of a m/s on a 10 kn ship, not nothing over a long track.
        """
        bearing = np.radians(np.asarray(course_deg, float)) - self.convergence(lat_deg, lon_deg)
        v = np.asarray(speed, float)
        return np.stack([v * np.sin(bearing), v * np.cos(bearing)], -1)

    def to_map_covariance(self, lat_deg, lon_deg, cov_en) -> np.ndarray:
        """(…, 2, 2) covariances in east/north [m²] at the points → in map (rotated by the convergence γ).

        A course c is the grid bearing c − γ (``to_map_velocity``), so a vector with true east/north
        components e is rot(γ)·e in map (rot: anticlockwise) and its covariance rot(γ) C rot(γ)ᵀ.
        """
        g = self.convergence(lat_deg, lon_deg)
        c, s = np.cos(g), np.sin(g)
        rot = np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)
        cov = np.asarray(cov_en, float)
        return rot @ cov @ np.swapaxes(rot, -1, -2)

    def earth_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """The pose of ``map`` in REP-105's ``earth`` (ECEF) frame: translation [m] (3,), quaternion (x, y, z, w).

        Module docstring: exact at the origin and along its axes; a placement on the globe, not a
        conversion of positions.
        """
        to_ecef = Transformer.from_crs('EPSG:4326', 'EPSG:4978', always_xy=True)
        t = np.array(to_ecef.transform(self.lon0, self.lat0, 0.0), float)
        phi, lam = math.radians(self.lat0), math.radians(self.lon0)
        east = [-math.sin(lam), math.cos(lam), 0.0]
        north = [-math.sin(phi) * math.cos(lam), -math.sin(phi) * math.sin(lam), math.cos(phi)]
        up = [math.cos(phi) * math.cos(lam), math.cos(phi) * math.sin(lam), math.sin(phi)]
        q = Rotation.from_matrix(np.array([east, north, up]).T).as_quat()   # columns: map's axes in ECEF
        return t, q

    def distance_to(self, lat0: float, lon0: float) -> float:
        """Ground distance [m] from this datum's origin to (lat0, lon0) (WGS-84 geodesic, pyproj.Geod)."""
        return float(_GEOD.inv(self.lon0, self.lat0, lon0, lat0)[2])

    def same_as(self, lat0: float, lon0: float, tol_m: float = DATUM_MATCH_M) -> bool:
        return self.distance_to(lat0, lon0) <= tol_m


class RunDatum:
    """One node's view of the run's one datum: its own origin, the datums heard, a conflict (module docstring).

    ``origin`` (lat, lon) is this node's own datum (a parameter), or None: the run's datum when
    one is heard, else this node's first fix (``fix``). With ``fallback`` the origin is no demand
    (a file's centroid): a datum heard before the node fixes its own is taken instead. The node
    publishes a datum it fixes; it reports what ``hear`` returns and refuses its input while
    ``conflict`` is set.

    Settling: ``settle`` seconds (on the caller's monotonic clock ``now``) after this node fixed,
    took or first agreed with a datum, that datum is the run's for this node, whatever is heard
    later: the earlier-stamp rule only settles nodes that fixed theirs at about the same time, and
    a different datum published once the run is going (a stray node, hostile input) is refused,
    not obeyed. Without ``now`` the datum never settles.
    """

    def __init__(self, origin: tuple[float, float] | None = None, *, fallback: bool = False,
                 settle: float = SETTLE_S) -> None:
        self.origin = None if origin is None else (float(origin[0]), float(origin[1]))
        self.fallback = fallback
        self.settle = float(settle)
        self.datum: Datum | None = None
        self.stamp = math.inf          # when this node's datum was published (inf: not published)
        self.taken = False             # the datum was heard, not fixed here
        self.conflict: str | None = None
        self.settled_at = math.inf     # from this time on [now] the datum is settled

    def _settle_from(self, now: float | None) -> None:
        if now is not None and self.settled_at == math.inf:
            self.settled_at = float(now) + self.settle

    def fix(self, lat: float, lon: float, t: float, now: float | None = None) -> Datum:
        """This node fixes the run's datum at ``t`` (its origin, or its first fix); the caller publishes it."""
        self.datum, self.stamp, self.taken = Datum(lat, lon), float(t), False
        self._settle_from(now)
        return self.datum

    def fix_own(self, t: float, now: float | None = None) -> Datum | None:
        """Fix this node's ``origin`` when no datum is known yet; the datum to publish, or None."""
        if self.datum is None and self.origin is not None:
            return self.fix(*self.origin, t, now)
        return None

    def hear(self, t: float, lat: float, lon: float, where: str = 'map_datum',
             now: float | None = None) -> tuple[str, str | None]:
        """A datum published by some node at ``t``, heard at ``now``: (event, line or None).

        Events: ``taken`` (this node had none: it is the run's now; a line to log), ``same``,
        ``conflict`` (theirs is the run's and differs from this node's own: ``conflict`` holds the
        reason; a line to log the first time), ``refused`` (theirs differs and this node's datum
        is the run's: it was published first, or it is settled; the line is the reason to refuse it).
        """
        if self.datum is None and self.origin is not None and not self.fallback:
            self.datum = Datum(*self.origin)          # not published yet: the one heard is the run's
        if self.datum is None:
            self.datum, self.stamp, self.taken = Datum(lat, lon), float(t), True
            self._settle_from(now)
            return 'taken', f'map datum {self.datum.describe()} taken from {where}'
        if self.datum.same_as(lat, lon):
            self._settle_from(now)
            return 'same', None
        theirs = f'({lat:.7f}°, {lon:.7f}°)'
        settled = now is not None and now >= self.settled_at
        if not settled and (t, lat, lon) < (self.stamp, self.datum.lat0, self.datum.lon0):   # theirs is the run's
            first = self.conflict is None
            self.conflict = (f'datum: this node\'s map datum {self.datum.describe()} differs from the run\'s '
                             f'{theirs} on {where}')
            line = (f'map datum conflict: this node\'s {self.datum.describe()} differs from the run\'s {theirs} on '
                    f'{where} ({self.datum.distance_to(lat, lon):.1f} m apart): its input is refused')
            return 'conflict', line if first else None
        why = 'settled' if settled else 'published first'
        return 'refused', f'datum: {theirs} differs from the run\'s {self.datum.describe()} ({why})'

    def problem(self) -> str | None:
        """Why a latitude/longitude cannot be placed in map now (a conflict, or no datum yet), else None."""
        if self.conflict is not None:
            return self.conflict
        if self.datum is None:
            return 'datum: no map datum known yet (none heard, no origin set)'
        return None
