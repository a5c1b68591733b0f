"""Latitude/longitude ↔ local east/north metres: the tangent plane at the data centroid (WGS-84).

Projection (:class:`LocalTangentPlane`): a geodetic point (φ, λ) on the WGS-84 ellipsoid
(height 0: ships are at sea level) goes to Earth-centred Earth-fixed (ECEF) coordinates and is
then expressed in the east/north/up (ENU) axes of the origin (φ0, λ0):

    N(φ) = a / √(1 − e² sin²φ)
    X = N cos φ cos λ,  Y = N cos φ sin λ,  Z = N (1 − e²) sin φ
    east  = −sin λ0 ΔX + cos λ0 ΔY
    north = −sin φ0 cos λ0 ΔX − sin φ0 sin λ0 ΔY + cos φ0 ΔZ

with a = 6 378 137 m, f = 1/298.257223563, e² = f (2 − f), Δ = P − P0. ``up`` is dropped: the
map is the orthographic projection of the ellipsoid onto its tangent plane at the origin, x
east and y north in metres (the ``map`` frame, ENU, REP-103). The inverse is exact: the point
of the plane is moved along the origin's normal back onto the ellipsoid (a quadratic in the
normal offset), and the geodetic latitude of a point on the surface is
atan(Z / ((1 − e²) √(X² + Y²))).

The local scale error is ≈ ρ²/(2R²) (ρ from the origin). :func:`extent_problem` names a set of
points reaching beyond ``MAX_SCALE_ERROR`` (0.1 %: ρ = 285 km); such a file is refused, to be split
by region or cut with ``max_distance_km``. The origin is the data centroid: the median latitude
and longitude of the valid reports (:func:`track_core.ais.reader.read_ais`).
Accuracy on the Solent and why refuse: docs/results/fusion.md, "The tangent plane".
"""

from __future__ import annotations

import numpy as np

WGS84_A = 6_378_137.0                    # semi-major axis [m]
WGS84_F = 1.0 / 298.257223563            # flattening
WGS84_E2 = WGS84_F * (2.0 - WGS84_F)     # first eccentricity squared
WGS84_B = WGS84_A * (1.0 - WGS84_F)      # semi-minor axis [m]


def geodetic_to_ecef(lat_deg, lon_deg) -> np.ndarray:
    """(…,) latitudes/longitudes in degrees at height 0 → (…, 3) ECEF metres."""
    phi, lam = np.radians(np.asarray(lat_deg, float)), np.radians(np.asarray(lon_deg, float))
    s = np.sin(phi)
    n = WGS84_A / np.sqrt(1.0 - WGS84_E2 * s * s)
    return np.stack([n * np.cos(phi) * np.cos(lam), n * np.cos(phi) * np.sin(lam), n * (1.0 - WGS84_E2) * s], -1)


def ecef_surface_to_geodetic(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(…, 3) ECEF points *on the ellipsoid* → (lat, lon) in degrees (exact for height 0)."""
    p = np.asarray(p, float)
    horiz = np.hypot(p[..., 0], p[..., 1])
    lat = np.degrees(np.arctan2(p[..., 2], (1.0 - WGS84_E2) * horiz))
    lon = np.degrees(np.arctan2(p[..., 1], p[..., 0]))
    return lat, lon


MAX_SCALE_ERROR = 1e-3   # radial scale error 1 − cos(ρ/R) allowed over the data (ρ = 285 km)
EARTH_MEAN_R = 6_371_000.0


def extent_problem(lat_deg, lon_deg, lat0: float, lon0: float, max_scale_error: float = MAX_SCALE_ERROR) -> str | None:
    """Why one tangent plane at (lat0, lon0) cannot hold the points (one line), or None (module docstring)."""
    lat, lon = np.radians(np.asarray(lat_deg, float)), np.radians(np.asarray(lon_deg, float))
    if lat.size == 0:
        return None
    p0, l0 = np.radians(lat0), np.radians(lon0)
    h = np.sin((lat - p0) / 2) ** 2 + np.cos(lat) * np.cos(p0) * np.sin((lon - l0) / 2) ** 2
    rho = 2 * EARTH_MEAN_R * np.arcsin(np.sqrt(np.clip(h, 0.0, 1.0)))   # great-circle distance [m]
    far = float(rho.max())
    limit = EARTH_MEAN_R * np.arccos(1.0 - max_scale_error)
    if far <= limit:
        return None
    share = float(np.mean(rho > limit))
    return (f'the positions reach {far / 1e3:,.0f} km from the projection origin ({lat0:.3f}°, {lon0:.3f}°), '
            f'{100 * share:.1f} % of them beyond {limit / 1e3:.0f} km, where one flat (tangent-plane) projection '
            f'distorts distances by more than {100 * max_scale_error:g} %: split the file by region or keep one '
            'region with max_distance_km')


class LocalTangentPlane:
    """East/north metres in the tangent plane of WGS-84 at (lat0, lon0); see the module docstring."""

    def __init__(self, lat0: float, lon0: float) -> None:
        if not (np.isfinite(lat0) and np.isfinite(lon0) and -90.0 < lat0 < 90.0 and -180.0 <= lon0 <= 180.0):
            raise ValueError(f'origin must be a finite latitude in (-90, 90) and longitude in [-180, 180], '
                             f'got ({lat0}, {lon0})')
        self.lat0, self.lon0 = float(lat0), float(lon0)
        phi, lam = np.radians(self.lat0), np.radians(self.lon0)
        self.p0 = geodetic_to_ecef(self.lat0, self.lon0)
        self.east = np.array([-np.sin(lam), np.cos(lam), 0.0])
        self.north = np.array([-np.sin(phi) * np.cos(lam), -np.sin(phi) * np.sin(lam), np.cos(phi)])
        self.up = np.array([np.cos(phi) * np.cos(lam), np.cos(phi) * np.sin(lam), np.sin(phi)])

    def forward(self, lat_deg, lon_deg) -> np.ndarray:
        """(…,) degrees → (…, 2) east/north metres."""
        d = geodetic_to_ecef(lat_deg, lon_deg) - self.p0
        return np.stack([d @ self.east, d @ self.north], -1)

    def inverse(self, en) -> tuple[np.ndarray, np.ndarray]:
        """(…, 2) east/north metres → (lat, lon) degrees on the ellipsoid (exact inverse of ``forward``)."""
        en = np.asarray(en, float)
        q = self.p0 + en[..., :1] * self.east + en[..., 1:2] * self.north      # point in the plane
        w = np.array([1.0 / WGS84_A**2, 1.0 / WGS84_A**2, 1.0 / WGS84_B**2])
        A = float(np.sum(w * self.up * self.up))
        B = np.sum(w * q * self.up, -1)
        C = np.sum(w * q * q, -1) - 1.0
        u = -C / (B + np.sqrt(B * B - A * C))          # the root near 0, written without cancellation
        return ecef_surface_to_geodetic(q + u[..., None] * self.up)
