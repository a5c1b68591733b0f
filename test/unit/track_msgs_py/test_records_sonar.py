"""Sonar records: the observer's mode and the smart target's status round-trip with the wire keys."""

from __future__ import annotations

import pytest

from track_msgs_py.records import RecordError, diagnostic_values
from track_msgs_py.records.sonar import SonarMode, SonarTargetStatus


def test_mode_round_trip_with_and_without_distance():
    rec = SonarMode('active', 'passive', 12, 187.25000000000003, 3.5)
    st = rec.to_status('obs/sensor_mode', message='active')
    assert diagnostic_values(st) == {'mode': 'active', 'next_mode': 'passive', 'step': '12',
                                     'ess': '187.25000000000003', 'distance': '3.5'}
    assert SonarMode.from_status(st) == rec
    base = SonarMode('passive', 'passive', 1, 200.0)
    assert 'distance' not in base.to_values() and SonarMode.from_values(base.to_values()) == base


def test_target_status_round_trip():
    rec = SonarTargetStatus('evade', True, 9, 4)
    assert rec.to_values() == {'mode': 'evade', 'heard': 'true', 'pings': '9', 'detections': '4'}
    assert SonarTargetStatus.from_status(rec.to_status('smart_target', message='evade')) == rec
    with pytest.raises(RecordError, match='detections'):
        SonarTargetStatus.from_values({'mode': 'cruise', 'heard': 'false', 'pings': '1', 'detections': 'x'})
