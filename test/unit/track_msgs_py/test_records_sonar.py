"""Sonar records: the observer's filter status and the smart target's status round-trip through CDR; a sonar
driver's contact, the mode request and the navigation convert both ways, and bad contacts are refused."""

from __future__ import annotations

import math

import numpy as np
import pytest
from rclpy.serialization import deserialize_message, serialize_message

from track_core.sonar.contacts import Contact
from track_core.sonar.models import SensorMode
from track_msgs import msg as tm
from track_msgs_py.records import RecordError
from track_msgs_py.records.sonar import (
    SonarFilterStatus,
    SonarTargetStatus,
    contact_from_msg,
    contact_to_msg,
    fix_from_odometry,
    fix_to_odometry,
    mode_command_from_msg,
    mode_command_to_msg,
)
from track_msgs_py.stamps import stamp_to_ns


@pytest.mark.parametrize('distance', [3.5, None])
def test_filter_status_round_trip_through_cdr(distance):
    rec = SonarFilterStatus(SensorMode.ACTIVE, SensorMode.PASSIVE, False, 12, 187.25000000000003, distance)
    msg = deserialize_message(serialize_message(rec.to_msg(5 * 10**9)), tm.SonarFilterStatus)
    assert stamp_to_ns(msg.header.stamp) == 5 * 10**9 and SonarFilterStatus.from_msg(msg) == rec
    msg.next_mode = 4
    with pytest.raises(RecordError, match='mode 4'):
        SonarFilterStatus.from_msg(msg)


def test_target_status_round_trip_through_cdr():
    rec = SonarTargetStatus('evade', True, 9, 4)
    msg = deserialize_message(serialize_message(rec.to_msg(3.0, 'smart_target')), tm.SonarTargetStatus)
    assert msg.target_id == 'smart_target' and msg.mode == tm.SonarTargetStatus.EVADE
    assert SonarTargetStatus.from_msg(msg) == rec
    msg.mode = 3
    with pytest.raises(RecordError, match='mode 3'):
        SonarTargetStatus.from_msg(msg)
    with pytest.raises(RecordError, match='sprint'):
        SonarTargetStatus('sprint', False, 0, 0).to_msg(1.0, 't')


# --- a sonar driver's messages ------------------------------------------------------------------------

def _contact(mode=SensorMode.ACTIVE, relative=False):
    R = np.diag([1e-4, 25.0]) if mode is SensorMode.ACTIVE else np.array([[1e-4]])
    return Contact(1_700_000_000_123_456_789, mode, -2.5, 420.0 if mode is SensorMode.ACTIVE else math.nan, R,
                   relative)


@pytest.mark.parametrize('mode', list(SensorMode))
def test_contact_round_trip_through_cdr(mode):
    c = _contact(mode)
    msg = deserialize_message(serialize_message(contact_to_msg(c, 'map')), tm.SonarContact)
    assert msg.header.frame_id == 'map' and stamp_to_ns(msg.header.stamp) == c.key
    back = contact_from_msg(msg, relative=False)
    assert (back.key, back.mode, back.yaw) == (c.key, c.mode, c.yaw)
    np.testing.assert_array_equal(back.R, c.R)
    assert back.range == c.range or (math.isnan(back.range) and math.isnan(c.range))


@pytest.mark.parametrize(('field', 'value', 'words'), [
    ('bearing', math.nan, 'non-finite bearing'),
    ('bearing', 100.0, 'degrees sent as radians'),
    ('bearing_std', 0.0, 'bearing_std'),
    ('bearing_std', 4.0, 'bearing_std'),
    ('range', -1.0, 'range -1'),
    ('range', 1e308, r'range 1e\+308'),
    ('range_std', math.inf, 'non-finite range_std'),
    ('mode', 7, 'mode 7'),
])
def test_a_bad_contact_is_refused_naming_the_field(field, value, words):
    msg = contact_to_msg(_contact(), 'map')
    setattr(msg, field, value)
    with pytest.raises(RecordError, match=words):
        contact_from_msg(msg, relative=False)


def test_a_passive_contact_ignores_its_range_fields():
    msg = contact_to_msg(_contact(SensorMode.PASSIVE), 'map')
    assert (msg.range, msg.range_std) == (0.0, 0.0)
    msg.range, msg.range_std = math.inf, -3.0
    assert contact_from_msg(msg, relative=True).relative


def test_mode_command_round_trip():
    msg = mode_command_to_msg(5 * 10**9, SensorMode.PASSIVE, 12.5)
    assert mode_command_from_msg(msg) == (5 * 10**9, SensorMode.PASSIVE) and msg.distance == 12.5
    assert mode_command_to_msg(0, SensorMode.ACTIVE, None).distance == -1.0
    msg.mode = 9
    with pytest.raises(RecordError, match='mode 9'):
        mode_command_from_msg(msg)


def test_navigation_is_read_per_rep105():
    """Heading along the velocity, forward speed in the body frame: read back as the world velocity."""
    vel = np.array([-3.0, 4.0])
    odom = fix_to_odometry(7 * 10**9, np.array([10.0, -2.0]), vel, 'map', 'ship')
    assert odom.child_frame_id == 'ship' and odom.twist.twist.linear.x == 5.0 and odom.twist.twist.linear.y == 0.0
    fix = fix_from_odometry(odom)
    assert fix.key == 7 * 10**9
    np.testing.assert_allclose(fix.xy, [10.0, -2.0])
    np.testing.assert_allclose(fix.velocity, vel, atol=1e-12)
    assert fix.heading == pytest.approx(math.atan2(4.0, -3.0), abs=1e-12)
