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


# --- bad command lines: one line on stderr, exit code 2 (issue 19, item 7) ---------------------------

@pytest.mark.parametrize(('content', 'args', 'words'), [
    (None, ['--params-file', '/nonexistent/params.yaml'], ['/nonexistent/params.yaml', 'No such file']),
    ('demo_target:\n  ros__parameters:\n    period: [1\n', None, ['not valid YAML', 'line 4']),
    ('- 1\n- 2\n', None, ['expected a mapping']),
    ('demo_target:\n  ros__parameters:\n    period: "x"\n', None, ['period', 'DOUBLE']),
    (None, ['--bogus-flag'], ['unknown ROS arguments', '--bogus-flag']),
    (None, ['--params-file'], ['a path is missing']),
])
def test_a_bad_command_line_gets_one_line_and_exit_code_2(tmp_path, prefix, env_factory, content, args, words):
    import subprocess
    if content is not None:
        (tmp_path / 'p.yaml').write_text(content)
        args = ['--params-file', str(tmp_path / 'p.yaml')]
    proc = subprocess.run([str(prefix / 'lib/track_nodes/demo_target'), '--ros-args', *args],
                          capture_output=True, text=True, timeout=60, env=env_factory())
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 2 and len(lines) == 1 and 'Traceback' not in proc.stderr, proc.stderr
    assert lines[0].startswith('demo_target: ') and all(w in lines[0] for w in words), lines[0]


def test_qos_of_every_endpoint_can_be_overridden_and_is_read_only(ros):
    """rclpy's QoS overrides (``qos_overrides.<topic>.<publisher|subscription>.<policy>``) reach our endpoints."""
    from rclpy.parameter import Parameter
    from rclpy.qos import ReliabilityPolicy

    from track_msgs_py.topics import DEMO_REPORTS, DEMO_TRUTH
    from track_nodes.demo.demo_target import DemoTargetNode
    from track_nodes.demo.demo_tracker import DemoTrackerNode

    target = ros.add(DemoTargetNode(context=ros.context, node_name='qos_target', parameter_overrides=[
        Parameter(f'qos_overrides.{DEMO_TRUTH}.publisher.depth', value=50),
        Parameter(f'qos_overrides.{DEMO_REPORTS}.publisher.reliability', value='best_effort')]))
    assert target.pub_truth.qos_profile.depth == 50
    assert target.pub_report.qos_profile.reliability is ReliabilityPolicy.BEST_EFFORT
    tracker = ros.add(DemoTrackerNode(context=ros.context, node_name='qos_tracker', parameter_overrides=[
        Parameter(f'qos_overrides.{DEMO_REPORTS}.subscription.depth', value=7)]))
    assert tracker.get_parameter(f'qos_overrides.{DEMO_REPORTS}.subscription.depth').value == 7
    result = target.set_parameters([Parameter(f'qos_overrides.{DEMO_TRUTH}.publisher.depth', value=3)])[0]
    assert not result.successful                                   # read-only once the endpoint exists
