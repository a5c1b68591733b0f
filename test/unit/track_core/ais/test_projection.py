"""Tangent-plane projection: exact round trip, axes, and distance accuracy over the Solent extent."""

import numpy as np
import pytest

from track_core.ais.projection import WGS84_A, WGS84_E2, LocalTangentPlane, geodetic_to_ecef

LAT0, LON0 = 50.79476, -1.11141  # the Solent data centroid


def _ellipsoidal_distance(lat1, lon1, lat2, lon2):
    """Geodesic length from the ECEF chord c: s = c + c³/(24 R²) (R: Gaussian radius; mm-accurate at 60 km)."""
    c = np.linalg.norm(geodetic_to_ecef(lat1, lon1) - geodetic_to_ecef(lat2, lon2), axis=-1)
    phi = np.radians(0.5 * (lat1 + lat2))
    w = 1.0 - WGS84_E2 * np.sin(phi) ** 2
    R = WGS84_A * np.sqrt(1.0 - WGS84_E2) / w  # √(M N)
    return c + c**3 / (24.0 * R**2)


def test_origin_and_axes():
    p = LocalTangentPlane(LAT0, LON0)
    np.testing.assert_allclose(p.forward(LAT0, LON0), [0.0, 0.0], atol=1e-9)
    east = p.forward(LAT0, LON0 + 0.01)
    north = p.forward(LAT0 + 0.01, LON0)
    assert east[0] > 700 and abs(east[1]) < 1.0          # 0.01° of longitude ≈ 704 m at 50.8° N
    assert north[1] > 1110 and abs(north[0]) < 1e-9      # 0.01° of latitude ≈ 1113 m, due north


def test_round_trip_is_exact():
    rng = np.random.default_rng(0)
    lat = LAT0 + rng.uniform(-0.35, 0.35, 2000)
    lon = LON0 + rng.uniform(-0.6, 0.6, 2000)
    p = LocalTangentPlane(LAT0, LON0)
    la, lo = p.inverse(p.forward(lat, lon))
    np.testing.assert_allclose(la, lat, atol=1e-10)      # 1e-10° ≈ 0.01 mm
    np.testing.assert_allclose(lo, lon, atol=1e-10)
    en = rng.uniform(-40e3, 40e3, (500, 2))
    np.testing.assert_allclose(p.forward(*p.inverse(en)), en, atol=1e-6)


def test_distance_error_over_the_solent_extent():
    """Documented: < 0.5 m and < 2e-5 relative for any two points within ~35 km of the centroid."""
    rng = np.random.default_rng(1)
    n = 5000
    lat = LAT0 + rng.uniform(-0.3, 0.1, (2, n))          # the data: 50.52..50.88 N
    lon = LON0 + rng.uniform(-0.3, 0.4, (2, n))          # -1.39..-0.73 E
    p = LocalTangentPlane(LAT0, LON0)
    d_plane = np.linalg.norm(p.forward(lat[0], lon[0]) - p.forward(lat[1], lon[1]), axis=1)
    d_true = _ellipsoidal_distance(lat[0], lon[0], lat[1], lon[1])
    err = np.abs(d_plane - d_true)
    print(f'max error {err.max():.3f} m, max relative {np.max(err / np.maximum(d_true, 1.0)):.2e}')
    assert err.max() < 0.5
    assert np.max(err / np.maximum(d_true, 1e3)) < 2e-5


def test_local_distances_scale_error():
    """Ships and ellipses are tens to hundreds of metres apart: scale error < 2e-5 (< 1 cm per 500 m)."""
    rng = np.random.default_rng(2)
    lat = LAT0 + rng.uniform(-0.3, 0.1, 1000)
    lon = LON0 + rng.uniform(-0.3, 0.4, 1000)
    lat2, lon2 = lat + 0.002 * rng.standard_normal(1000), lon + 0.003 * rng.standard_normal(1000)
    p = LocalTangentPlane(LAT0, LON0)
    d = np.linalg.norm(p.forward(lat, lon) - p.forward(lat2, lon2), axis=1)
    np.testing.assert_allclose(d, _ellipsoidal_distance(lat, lon, lat2, lon2), rtol=2e-5, atol=1e-4)


@pytest.mark.parametrize('origin', [(91.0, 0.0), (np.nan, 0.0), (50.0, 200.0), (90.0, 0.0)])
def test_bad_origin_raises(origin):
    with pytest.raises(ValueError, match='origin'):
        LocalTangentPlane(*origin)
