"""``node_group`` (issue 19, item 8): the whole IDSQ field as one process, each sensor still a ROS node.

On wall time, started by hand: the sensors count steps from the layout's stamp (vehicle_sim's
clock origin), so no /clock is needed (issue 19: no clock origin shared by convention).
"""

from __future__ import annotations

import signal
import subprocess

import pytest
from rclpy.node import Node

from track_msgs import msg as tm
from track_msgs_py.qos import ESTIMATE_QOS
from track_msgs_py.topics import IDSQ_LEADER
from track_nodes.launch.scenario import load_scenario

pytestmark = pytest.mark.integration


def test_the_idsq_field_runs_in_one_process(ros, repo, prefix):
    sc = load_scenario('idsq')
    entries = [f'{s.executable}:{s.name}' for s in sc.nodes]
    probe = ros.add(Node('group_probe', context=ros.context))
    events: list = []
    probe.create_subscription(tm.IdsqLeaderEvent, IDSQ_LEADER, events.append, ESTIMATE_QOS)
    proc = subprocess.Popen([str(prefix / 'lib/track_nodes/node_group'), '--nodes', *entries,
                             '--ros-args', '--params-file', str(sc.path)],
                            env=ros.env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        want = {s.name for s in sc.nodes}
        assert ros.spin_until(lambda: want <= set(probe.get_node_names()), timeout=120), \
            sorted(want - set(probe.get_node_names()))
        assert ros.spin_until(lambda: len(events) >= 3, timeout=120), 'no leader events from the field'
    finally:
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=60)
    assert proc.returncode == 0 and 'Traceback' not in err, err


@pytest.mark.parametrize(('extra', 'words'), [
    (['--nodes', 'no_such_node'], ['unknown executable', 'no_such_node']),
    (['--nodes', 'demo_target', 'demo_target'], ['repeated', 'demo_target']),
    (['--nodes', 'demo_target', '--ros-args', '-p', 'period:=-1.0'], ['demo_target', 'period']),
])
def test_a_bad_group_is_one_line_and_exit_code_2(prefix, env_factory, extra, words):
    proc = subprocess.run([str(prefix / 'lib/track_nodes/node_group'), *extra], capture_output=True, text=True,
                          timeout=60, env=env_factory())
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 2 and len(lines) == 1 and 'Traceback' not in proc.stderr, proc.stderr
    assert all(w in lines[0] for w in words), lines[0]


@pytest.mark.parametrize('delay', [0.3, 1.5, 3.0])
def test_ctrl_c_at_any_moment_of_the_start_is_clean(ros, prefix, delay):
    """SIGINT while importing, while building the 25 nodes or while they run: no traceback (issue 19, item 8)."""
    sc = load_scenario('idsq')
    proc = subprocess.Popen([str(prefix / 'lib/track_nodes/node_group'), '--nodes',
                             *[f'{s.executable}:{s.name}' for s in sc.nodes], '--ros-args', '--params-file',
                             str(sc.path)], env=ros.env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        ros.spin_for(delay)  # the moment under test, not a wait for a condition
    finally:
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=60)
    # 0: stopped cleanly; 130: interrupted while importing; -SIGINT: before Python had started at all
    assert proc.returncode in (0, 130, -signal.SIGINT) and 'Traceback' not in err, err
