"""One datum per run: WGS-84 latitude/longitude ⇄ ``map`` east/north metres through PROJ (pyproj).

Why a library: a projection written by hand is one more thing to get wrong and to test; PROJ is
the reference implementation used by every GIS. Why one origin: two nodes that project about
different origins put the same ship at two ``map`` positions, and nothing downstream can tell.

The ``map`` frame is the transverse Mercator projection of the WGS-84 ellipsoid about the origin
(φ0, λ0) with scale 1 on the central meridian and no false easting/northing (PROJ
``+proj=tmerc +lat_0=φ0 +lon_0=λ0 +k_0=1 +x_0=0 +y_0=0 +ellps=WGS84``, Poder/Engsager's
series, accurate to millimetres within thousands of km of the meridian): x east, y north (REP-103),
the origin at (0, 0). It is conformal, so an ellipse keeps its shape; its point scale is
k ≈ 1 + x²/(2R²): 1.1·10⁻⁵ at 30 km, 10⁻³ (1 m per km) at 285 km from the central meridian, the
same extent ``projection.MAX_SCALE_ERROR`` allows a tangent plane. Grid north (+y) turns from true north by
the meridian convergence γ ≈ Δλ·sin φ (0.3° at 30 km east of the origin at 51° N):
``Datum.to_map_velocity`` rotates a course over ground by it, so a velocity and the track of the
positions agree.

Within a few km of the origin this map and the tangent plane of ``projection.LocalTangentPlane`` agree to
millimetres; at 30 km they differ by about ρ³/(6R²) ≈ 0.1 m (the test measures it).
"""

from __future__ import annotations

import math

import numpy as np
from pyproj import CRS, Geod, Transformer
from pyproj.exceptions import ProjError

_GEOD = Geod(ellps='WGS84')
NORTH_STEP_DEG = 1e-5   # the step north that measures the meridian convergence [deg]
DATUM_MATCH_M = 0.01   # two origins closer than this on the ground are the same datum [m]


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

    def distance_to(self, lat0: float, lon0: float) -> float:
        """Ground distance [m] from this datum's origin to (lat0, lon0) (WGS-84 geodesic, pyproj.Geod)."""
        return float(_GEOD.inv(self.lon0, self.lat0, lon0, lat0)[2])

    def same_as(self, lat0: float, lon0: float, tol_m: float = DATUM_MATCH_M) -> bool:
        return self.distance_to(lat0, lon0) <= tol_m
