"""Live AIS reports: covariance from the accuracy flag, velocity from SOG/COG, "not available", bounds, ship table."""

import math

import numpy as np
import pytest

from track_core.ais.datum import Datum
from track_core.ais.live import (
    KNOT,
    SIGMA_HIGH,
    SIGMA_LOW,
    SIGMA_SOG,
    FeedWatch,
    PositionFields,
    ShipTable,
    position_problem,
    state_report,
)

DATUM = Datum(50.8, -1.2)


def _f(**kw):
    base = dict(msg_type=1, mmsi=235000001, lat=50.81, lon=-1.19, sog=10.0, cog=90.0, heading=91.0, accuracy=True)
    return PositionFields(**{**base, **kw})


def test_high_and_low_accuracy_fixes():
    hi, lo = state_report(_f(accuracy=True), 0.0, DATUM), state_report(_f(accuracy=False), 0.0, DATUM)
    np.testing.assert_allclose(hi.R, np.eye(2) * SIGMA_HIGH**2)
    np.testing.assert_allclose(lo.R, np.eye(2) * SIGMA_LOW**2)
    assert 2 * SIGMA_HIGH == 10.0 and 2 * SIGMA_LOW > 10.0        # the flag's 10 m is the high fix's 2σ
    np.testing.assert_allclose(hi.z, DATUM.forward(50.81, -1.19))


def test_velocity_from_sog_and_cog():
    r = state_report(_f(sog=10.0, cog=90.0), 0.0, DATUM)
    assert r.v[0] == pytest.approx(10 * KNOT, rel=1e-4) and abs(r.v[1]) < 0.01
    # along the course (east) σ_SOG, across it speed·2°
    assert r.Pv[0, 0] == pytest.approx(SIGMA_SOG**2, rel=1e-3)
    assert r.Pv[1, 1] == pytest.approx((10 * KNOT * math.radians(2.0)) ** 2, rel=1e-3)
    assert r.heading_deg == 91.0


@pytest.mark.parametrize('kw', [dict(sog=102.3), dict(cog=360.0), dict(sog=102.3, cog=360.0)])
def test_not_available_speed_or_course_is_not_estimated(kw):
    r = state_report(_f(**kw), 0.0, DATUM)
    assert position_problem(_f(**kw)) is None and r.v is None and r.Pv is None


def test_stopped_without_course_is_zero_velocity_and_heading_511_is_none():
    r = state_report(_f(sog=0.0, cog=360.0, heading=511), 0.0, DATUM)
    np.testing.assert_allclose(r.v, [0.0, 0.0])
    assert r.heading_deg is None


@pytest.mark.parametrize('kw, field', [
    (dict(lat=91.0), 'position'), (dict(lon=181.0), 'position'), (dict(lat=-95.0), 'lat'), (dict(lon=200.0), 'lon'),
    (dict(sog=120.0), 'sog'), (dict(cog=400.0), 'cog'), (dict(heading=400.0), 'heading'), (dict(mmsi=0), 'mmsi'),
    (dict(lat=math.nan), 'lat'), (dict(msg_type=5), 'msg_type'),
])
def test_out_of_range_or_unavailable_positions_are_refused(kw, field):
    reason = position_problem(_f(**kw))
    assert reason is not None and reason.startswith(f'{field}:'), reason


def test_ship_table_is_bounded_and_orders_reports():
    table = ShipTable(max_ships=3, forget_after=100.0)
    for k in range(5):
        table.position(100 + k, t=10.0, now=float(k))
    assert len(table) == 3 and table.forgotten == 2 and list(table.ships) == [102, 103, 104]
    assert table.order_problem(104, 9.0).startswith('stamp:') and table.order_problem(104, 10.0) is None
    ship, changed = table.static(104, 5.0, name='RED FUNNEL', ship_type=60)
    assert changed and ship.name == 'RED FUNNEL' and not table.static(104, 5.0, name='RED FUNNEL')[1]
    assert table.expire(104.5) == 2 and list(table.ships) == [104]      # 102, 103 silent > 100 s


def test_feed_watch_reports_a_silence_once_and_the_return():
    w = FeedWatch(silence=10.0)
    assert w.check(5.0, started=0.0) is None
    assert w.check(10.0, started=0.0) == pytest.approx(10.0)
    assert w.check(20.0, started=0.0) is None          # once per silence
    assert w.heard(21.0) is True and w.heard(22.0) is False
    assert w.check(31.5, started=0.0) is None and w.check(32.0, started=0.0) == pytest.approx(10.0)
