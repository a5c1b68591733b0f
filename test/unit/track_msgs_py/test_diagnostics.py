"""DiagnosticStatus and DiagnosticArray built from names, levels and values, also through CDR."""

import pytest
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from rclpy.serialization import deserialize_message, serialize_message

from track_msgs_py.diagnostics import diagnostic_array, diagnostic_status
from track_msgs_py.stamps import stamp_to_sec


def cdr(msg):
    """Serialise and deserialise: what a subscriber or a bag reader gets."""
    return deserialize_message(serialize_message(msg), type(msg))


def test_diagnostic_status_and_array():
    st = diagnostic_status('demo_tracker', 1, 'dropped reports', {'rejected': 3, 'nees': 4.25}, hardware_id='hw')
    st2 = cdr(st)
    assert st2.level == DiagnosticStatus.WARN and st2.name == 'demo_tracker' and st2.hardware_id == 'hw'
    assert [(kv.key, kv.value) for kv in st2.values] == [('rejected', '3'), ('nees', '4.25')]
    assert diagnostic_status('x', DiagnosticStatus.ERROR, '', {}).level == DiagnosticStatus.ERROR
    arr = cdr(diagnostic_array(3.0, [st]))
    assert isinstance(arr, DiagnosticArray) and stamp_to_sec(arr.header.stamp) == 3.0 and len(arr.status) == 1
    with pytest.raises(ValueError, match='level'):
        diagnostic_status('x', 4, '', {})
