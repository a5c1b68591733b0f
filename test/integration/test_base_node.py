"""TrackNode.refuse: counted per reason, throttled in the log, and visible on /diagnostics."""

from __future__ import annotations

import pytest
import rclpy
from diagnostic_msgs.msg import DiagnosticArray

from track_msgs_py.records import DIAG_WARN, diagnostic_values
from track_msgs_py.topics import DIAGNOSTICS
from track_nodes.base import TrackNode

pytestmark = pytest.mark.integration


class _Refuser(TrackNode):
    DEFAULT_NAME = 'refuser'


def test_refusals_are_counted_and_published_on_diagnostics(ros):
    node = ros.add(_Refuser(context=ros.context))
    got: list[DiagnosticArray] = []
    listener = ros.add(rclpy.create_node('listener', context=ros.context))
    listener.create_subscription(DiagnosticArray, DIAGNOSTICS, got.append, 10)
    node.refuse('/x', 'pose.covariance: smallest variance 0 is below the floor 1e-12')
    assert ros.spin_until(lambda: listener.count_publishers(DIAGNOSTICS) > 0, 30.0)
    for _ in range(99):
        node.refuse('/x', 'pose.covariance: smallest variance 0 is below the floor 1e-12')
    node.refuse('/y', 'header.stamp: zero stamp (a time is required)')

    def latest_counts() -> dict[str, str]:
        return diagnostic_values(got[-1].status[0]) if got else {}

    assert ros.spin_until(lambda: latest_counts() == {'/x pose.covariance': '100', '/y header.stamp': '1'}, 30.0), \
        latest_counts()
    st = got[-1].status[0]
    assert st.name == '/refuser' and st.level == bytes([DIAG_WARN]) and st.message == '101 messages refused'
    assert node.refusals.total() == 101
