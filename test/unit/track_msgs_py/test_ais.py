"""track_msgs_py.ais: the datum as a NavSatFix and as earth → map, a NavSatFix as a position in map."""

import math

import numpy as np
import pytest
from sensor_msgs.msg import NavSatFix

from track_core.ais.datum import Datum
from track_msgs_py.ais import (
    datum_to_transform,
    navsatfix_position_problem,
    navsatfix_to_position,
)
from track_msgs_py.stamps import sec_to_stamp, stamp_to_sec


def _fix(lat=50.8, lon=-0.8, cov=((4.0, 1.0), (1.0, 9.0)), kind=NavSatFix.COVARIANCE_TYPE_DIAGONAL_KNOWN, status=0):
    msg = NavSatFix(latitude=lat, longitude=lon, position_covariance_type=kind)
    msg.header.stamp = sec_to_stamp(12.5)
    msg.status.status = status
    c = np.zeros((3, 3))
    c[:2, :2] = cov
    c[2, 2] = 25.0
    msg.position_covariance = c.ravel().tolist()
    return msg


def test_the_map_in_the_earth_frame_as_a_transform():
    d = Datum(50.8, -1.2)
    tr = datum_to_transform(3.0, d)
    t, q = d.earth_pose()
    assert (tr.header.frame_id, tr.child_frame_id, stamp_to_sec(tr.header.stamp)) == ('earth', 'map', 3.0)
    v, r = tr.transform.translation, tr.transform.rotation
    np.testing.assert_allclose([v.x, v.y, v.z, r.x, r.y, r.z, r.w], [*t, *q])
    assert math.hypot(v.x, v.y, v.z) == pytest.approx(6_365_000, abs=5_000)   # on the ellipsoid at 50.8° N


def test_a_fix_becomes_a_map_position_through_the_datum():
    d = Datum(50.8, -1.2)
    msg = _fix()
    assert navsatfix_position_problem(msg) is None
    t, z, R = navsatfix_to_position(msg, d)
    assert t == 12.5
    np.testing.assert_allclose(z, d.forward(50.8, -0.8))
    np.testing.assert_allclose(R, d.to_map_covariance(50.8, -0.8, [[4.0, 1.0], [1.0, 9.0]]))
    np.testing.assert_allclose(R, R.T)


@pytest.mark.parametrize(('kw', 'why'), [
    ({'lat': math.nan}, 'latitude'),
    ({'lon': 181.0}, 'longitude'),
    ({'status': -1}, 'no fix'),
    ({'kind': NavSatFix.COVARIANCE_TYPE_UNKNOWN}, 'position_covariance_type: unknown'),
    ({'cov': ((4.0, 9.0), (9.0, 4.0))}, 'position_covariance'),
    ({'cov': ((math.inf, 0.0), (0.0, 4.0))}, 'position_covariance'),
    ({'cov': ((1e300, 0.0), (0.0, 4.0))}, 'position_covariance'),
])
def test_a_bad_fix_is_refused_with_a_reason(kw, why):
    assert why in navsatfix_position_problem(_fix(**kw))
