"""The map datum: PROJ's transverse Mercator about one origin, against published geodesy and the tangent plane."""

import math

import numpy as np
import pytest
from pyproj import Geod

from track_core.ais.datum import Datum
from track_core.ais.projection import LocalTangentPlane


def _dms(d, m, s):
    return math.copysign(abs(d) + m / 60 + s / 3600, d)


# Geoscience Australia's worked example of Vincenty's inverse formula (GRS80, which differs from WGS-84 by
# 0.1 mm in the semi-minor axis): Flinders Peak → Buninyong, 54 972.271 m at azimuth 306°52'05.37".
FLINDERS = (_dms(-37, 57, 3.72030), _dms(144, 25, 29.52440))
BUNINYONG = (_dms(-37, 39, 10.15610), _dms(143, 55, 35.38390))
GA_DISTANCE = 54_972.271
GA_AZIMUTH = _dms(306, 52, 5.37)


def test_published_geodesic_is_reproduced_in_the_map():
    """Buninyong in the map of a datum at Flinders Peak: the distance within the projection's scale error.

    The line runs 44 km west of the central meridian, where transverse Mercator stretches by
    ≈ 1 + x²/(6R²) on average (8·10⁻⁶, 0.44 m over 55 km); the azimuth at the origin within 10"
    (the chord's arc-to-chord correction is a few seconds here)."""
    d = Datum(*FLINDERS)
    x, y = d.forward(*BUNINYONG)
    assert math.hypot(x, y) == pytest.approx(GA_DISTANCE, abs=1.0)
    assert math.hypot(x, y) - GA_DISTANCE > 0                       # TM stretches away from its meridian
    azimuth = math.degrees(math.atan2(x, y)) % 360
    assert azimuth == pytest.approx(GA_AZIMUTH, abs=10 / 3600)
    # and the library's own geodesic (Karney) agrees with the published figures to the millimetre
    az, _, s = Geod(ellps='WGS84').inv(FLINDERS[1], FLINDERS[0], BUNINYONG[1], BUNINYONG[0])
    assert s == pytest.approx(GA_DISTANCE, abs=2e-3) and az % 360 == pytest.approx(GA_AZIMUTH, abs=0.01 / 3600)


def test_origin_axes_and_round_trip():
    d = Datum(50.79476, -1.11141)
    np.testing.assert_allclose(d.forward(50.79476, -1.11141), [0.0, 0.0], atol=1e-6)
    east, north = d.forward(50.79476, -1.10141), d.forward(50.80476, -1.11141)
    assert east[0] > 700 and abs(east[1]) < 0.1 and north[1] > 1110 and abs(north[0]) < 1e-6
    rng = np.random.default_rng(0)
    lat, lon = 50.8 + rng.uniform(-0.35, 0.35, 500), -1.1 + rng.uniform(-0.6, 0.6, 500)
    la, lo = d.inverse(d.forward(lat, lon))
    np.testing.assert_allclose(la, lat, atol=1e-9)
    np.testing.assert_allclose(lo, lon, atol=1e-9)


def test_distances_match_the_geodesic_over_a_harbour():
    """Within 35 km of the origin, map distances are the WGS-84 geodesic's within 2·10⁻⁵ (the tangent plane's bound)."""
    d = Datum(50.79476, -1.11141)
    rng = np.random.default_rng(1)
    lat = 50.79476 + rng.uniform(-0.3, 0.3, (400, 2))
    lon = -1.11141 + rng.uniform(-0.45, 0.45, (400, 2))
    p = d.forward(lat, lon)
    mapped = np.linalg.norm(p[:, 0] - p[:, 1], axis=-1)
    _, _, s = Geod(ellps='WGS84').inv(lon[:, 0], lat[:, 0], lon[:, 1], lat[:, 1])
    assert np.max(np.abs(mapped - s) / s) < 2e-5


def test_agrees_with_the_tangent_plane_near_the_origin():
    d, plane = Datum(50.79476, -1.11141), LocalTangentPlane(50.79476, -1.11141)
    near = d.forward([50.80, 50.78], [-1.10, -1.13]) - plane.forward([50.80, 50.78], [-1.10, -1.13])
    assert np.abs(near).max() < 1e-3                                     # 2 km: the same map to the mm
    far = d.forward(50.9, -0.7) - plane.forward(50.9, -0.7)              # 30 km: ρ³/(6R²) ≈ 0.1 m
    assert 0.01 < np.abs(far).max() < 0.5


def test_a_course_is_turned_to_grid_north():
    d = Datum(50.8, -1.2)
    assert d.convergence(50.8, -1.2) == pytest.approx(0.0, abs=1e-9)
    east = float(d.convergence(50.8, -0.8))            # 28 km east: γ ≈ Δλ sin φ = 0.4° · 0.775
    assert math.degrees(east) == pytest.approx(0.4 * math.sin(math.radians(50.8)), rel=1e-3)
    v = d.to_map_velocity(50.8, -0.8, 5.0, 0.0)         # due north (true) leans west on the grid
    assert v[0] < 0 and math.hypot(*v) == pytest.approx(5.0)
    # a ship steaming due north really moves along the grid line its velocity says
    step = d.forward(50.8 + 0.001, -0.8) - d.forward(50.8, -0.8)
    assert math.atan2(step[0], step[1]) == pytest.approx(math.atan2(v[0], v[1]), abs=1e-5)


@pytest.mark.parametrize('origin', [(91.0, 0.0), (0.0, 181.0), (math.nan, 0.0)])
def test_a_bad_origin_is_refused(origin):
    with pytest.raises(ValueError, match='datum origin'):
        Datum(*origin)


def test_same_as_within_a_centimetre():
    d = Datum(50.8, -1.2)
    assert d.same_as(50.8, -1.2) and d.same_as(50.8 + 5e-8, -1.2)       # 5.6 mm
    assert not d.same_as(50.8 + 1e-6, -1.2)                               # 11 cm


def test_a_covariance_on_the_earth_is_turned_like_the_projection():
    """An east/north covariance 28 km east of the origin: rotated by γ, as the projection's own Jacobian does."""
    d = Datum(50.8, -1.2)
    lat, lon = 50.8, -0.8
    local = LocalTangentPlane(lat, lon)                 # true east/north metres at the point
    h = 1.0
    J = np.stack([(d.forward(*local.inverse([h, 0.0])) - d.forward(*local.inverse([-h, 0.0]))) / (2 * h),
                  (d.forward(*local.inverse([0.0, h])) - d.forward(*local.inverse([0.0, -h]))) / (2 * h)], -1)
    k = math.sqrt(abs(np.linalg.det(J)))                # the point scale, 1 + 1e-5 here: neglected
    assert k == pytest.approx(1.0, abs=2e-5)
    C = np.array([[100.0, 30.0], [30.0, 400.0]])
    np.testing.assert_allclose(d.to_map_covariance(lat, lon, C), J @ C @ J.T / k**2, atol=1e-3)
    assert not np.allclose(d.to_map_covariance(lat, lon, C), C, atol=0.1)   # γ = 0.31°: not the identity
    batch = d.to_map_covariance([lat, 50.8], [lon, -1.2], np.stack([C, C]))
    np.testing.assert_allclose(batch[1], C, atol=1e-9)                       # on the central meridian: unchanged


def test_the_map_in_the_earth_frame():
    """map's pose in ECEF: the origin's ECEF point and its east/north/up axes (projection.py's own formulas)."""
    from scipy.spatial.transform import Rotation

    d = Datum(50.8, -1.2)
    t, q = d.earth_pose()
    plane = LocalTangentPlane(50.8, -1.2)
    np.testing.assert_allclose(t, plane.p0, atol=1e-6)
    R = Rotation.from_quat(q).as_matrix()
    np.testing.assert_allclose(R, np.stack([plane.east, plane.north, plane.up], -1), atol=1e-12)
    # a ship 2 km from the origin: map (the projection) and earth → map (the plane) agree to a metre across, and
    # the ship lies ρ²/(2R) = 0.3 m below the plane
    lat, lon = Datum(50.8, -1.2).inverse([1200.0, 1600.0])
    from track_core.ais.projection import geodetic_to_ecef

    in_map = R.T @ (geodetic_to_ecef(lat, lon) - t)
    np.testing.assert_allclose(in_map[:2], [1200.0, 1600.0], atol=1e-2)
    assert in_map[2] == pytest.approx(-2000.0**2 / (2 * 6.38e6), rel=0.02)


def test_one_datum_per_run():
    from track_core.ais.datum import RunDatum

    run = RunDatum()
    assert 'no map datum' in run.problem()
    assert run.hear(5.0, 50.8, -1.2)[0] == 'taken' and run.datum.same_as(50.8, -1.2) and run.problem() is None
    assert run.hear(6.0, 50.8, -1.2) == ('same', None)
    event, line = run.hear(7.0, 50.0, -1.0)                          # a later, different datum: refused
    assert event == 'refused' and '(50.0000000°, -1.0000000°)' in line and run.problem() is None

    own = RunDatum(origin=(50.0, -1.0))
    event, line = own.hear(5.0, 50.8, -1.2, '/map_datum')            # heard before publishing its own: conflict
    assert event == 'conflict' and '/map_datum' in line
    assert '(50.0000000°, -1.0000000°)' in own.problem() and '(50.8000000°, -1.2000000°)' in own.problem()
    assert own.hear(6.0, 50.8, -1.2) == ('conflict', None)           # reported once
    assert own.fix_own(9.0) is None                                  # nothing to publish: it has a datum

    first = RunDatum(origin=(50.0, -1.0))
    assert first.fix_own(3.0).same_as(50.0, -1.0) and first.fix_own(4.0) is None
    assert first.hear(5.0, 50.8, -1.2)[0] == 'refused' and first.problem() is None   # published first: the run's
    tie = RunDatum(origin=(50.9, -1.0))
    tie.fix_own(3.0)
    assert tie.hear(3.0, 50.8, -1.2)[0] == 'conflict'                # same stamp: the smaller latitude wins


def test_a_fallback_origin_gives_way_to_the_run_datum():
    from track_core.ais.datum import RunDatum

    centroid = RunDatum(origin=(50.0, -1.0), fallback=True)
    assert centroid.hear(5.0, 50.8, -1.2)[0] == 'taken' and centroid.datum.same_as(50.8, -1.2)
    assert centroid.fix_own(6.0) is None and centroid.problem() is None
    alone = RunDatum(origin=(50.0, -1.0), fallback=True)
    assert alone.fix_own(1.0).same_as(50.0, -1.0)                    # nothing heard: its own, published
    assert alone.hear(5.0, 50.8, -1.2)[0] == 'refused'
    assert alone.hear(0.5, 50.8, -1.2)[0] == 'conflict'              # an earlier one heard late: refused


def test_a_settled_datum_refuses_an_earlier_stamped_one():
    """Nodes that fixed their datums at about the same time agree on the earlier; once settled, a different
    datum heard (a stray node, a hostile message stamped at 0) is refused and changes nothing."""
    from track_core.ais.datum import RunDatum

    run = RunDatum(settle=2.0)
    assert run.hear(10.0, 50.8, -1.2, now=100.0)[0] == 'taken'
    assert run.hear(9.0, 50.0, -1.0, now=101.0)[0] == 'conflict'       # within 2 s: the earlier one is the run's
    settled = RunDatum(settle=2.0)
    settled.fix(50.8, -1.2, 10.0, now=100.0)
    event, line = settled.hear(0.0, 0.0, 0.0, now=102.5)                 # stamped 0: earlier, but too late
    assert event == 'refused' and 'settled' in line and settled.problem() is None
    agreed = RunDatum(origin=(50.8, -1.2))                               # agreed with the run's: settles too
    assert agreed.hear(10.0, 50.8, -1.2, now=100.0)[0] == 'same'
    assert agreed.hear(0.0, 0.0, 0.0, now=103.0)[0] == 'refused' and agreed.problem() is None
