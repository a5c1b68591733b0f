"""Managed (lifecycle) estimator nodes (``track_nodes.base.lifecycle``), driven through the real services.

Each estimator runs as its ``lifecycle_<executable>`` class beside the plain node that feeds it, in
one process; a client node calls ``~/change_state`` and ``~/get_state`` (lifecycle_msgs) as
``ros2 lifecycle set`` does. Checked: unconfigured has no topic endpoint; inactive has its endpoints
but publishes nothing while its input flows (held, not processed); active publishes; deactivate stops it again; cleanup
removes the endpoints and what setup() built, and a second configure → activate works afresh.
"""

from __future__ import annotations

import importlib

import pytest
from geometry_msgs.msg import PoseWithCovarianceStamped
from lifecycle_msgs.msg import Transition
from lifecycle_msgs.srv import ChangeState, GetAvailableStates, GetState
from rclpy.node import Node

from track_msgs_py.qos import SENSOR_SUB_QOS, qos_for_topic
from track_msgs_py.topics import (
    DEMO_REPORTS,
    DEMO_TRACK,
    FUSION_SCORES,
    RFID_COMMAND,
    SLAM_POSE,
    SLAM_SCAN,
    SONAR_ESTIMATE,
    TOPICS,
)
from track_nodes.registry import LIFECYCLE, node_class

# lifecycle executable: (scenario file, feeding nodes (executable, name), output topic, input topic or None)
CASES = {
    'lifecycle_demo_tracker': ('demo', [('demo_target', 'demo_target')], DEMO_TRACK, DEMO_REPORTS),
    'lifecycle_fusion': ('fusion', [('report_source', 'radar'), ('report_source', 'patrol')], FUSION_SCORES,
                         '/radar/t0'),
    'lifecycle_slam': ('slam_sim', [('slam_sim', 'slam_sim')], SLAM_POSE, SLAM_SCAN),
    'lifecycle_sonar_observer': ('sonar', [('smart_target', 'smart_target'), ('sonar_sim', 'sonar_sim')],
                                 SONAR_ESTIMATE, None),
    'lifecycle_rfid_guidance': ('rfid', [('rfid_reader', 'rfid_reader')], RFID_COMMAND, None),
}
INPUTS = 5  # input messages seen while inactive before "no output" is concluded


def _msg_class(topic: str):
    pkg, _, name = TOPICS[topic].msgtype.split('/')
    return getattr(importlib.import_module(f'{pkg}.msg'), name)


class Manager:
    """A client node calling a managed node's lifecycle services, as ``ros2 lifecycle`` does."""

    def __init__(self, ros, target: str) -> None:
        self.ros = ros
        self.node = ros.add(Node('lifecycle_manager', context=ros.context))
        self.change = self.node.create_client(ChangeState, f'/{target}/change_state')
        self.get = self.node.create_client(GetState, f'/{target}/get_state')

    def _call(self, client, request):
        assert self.ros.spin_until(client.service_is_ready, timeout=30), client.srv_name
        future = client.call_async(request)
        assert self.ros.spin_until(future.done, timeout=30), f'{client.srv_name}: no answer'
        return future.result()

    def state(self) -> str:
        return self._call(self.get, GetState.Request()).current_state.label

    def set(self, transition: int) -> bool:
        return self._call(self.change, ChangeState.Request(transition=Transition(id=transition))).success


def test_every_estimator_has_a_lifecycle_executable():
    assert set(LIFECYCLE) >= set(CASES)
    cls = node_class('lifecycle_fusion')
    assert cls.DEFAULT_NAME == 'fusion' and 'Managed (lifecycle)' in cls.__doc__
    assert node_class('lifecycle_fusion') is cls                  # one class per executable


@pytest.mark.parametrize('exe', sorted(CASES))
def test_configure_activate_deactivate_cleanup_through_the_services(ros, repo, exe):
    scenario, feeders, output, input_topic = CASES[exe]
    params = ['--ros-args', '--params-file', str(repo / f'config/{scenario}.yaml')]
    cls = node_class(exe)
    node = ros.add(cls(context=ros.context, cli_args=params))
    name = node.get_name()
    constructed = {k for k in vars(node) if not k.startswith('_lc_')}
    for feeder, feeder_name in feeders:
        ros.add(node_class(feeder)(node_name=feeder_name, context=ros.context, cli_args=params))
    sink = ros.add(Node('lifecycle_sink', context=ros.context))
    got = {'out': 0, 'in': 0}
    sink.create_subscription(_msg_class(output), output, lambda _: got.__setitem__('out', got['out'] + 1),
                             qos_for_topic(output))
    if input_topic is not None:
        in_type = _msg_class(input_topic) if input_topic in TOPICS else PoseWithCovarianceStamped  # fusion's input
        sink.create_subscription(in_type, input_topic, lambda _: got.__setitem__('in', got['in'] + 1),
                                 SENSOR_SUB_QOS)   # best effort: matches any publisher
    manager = Manager(ros, name)

    def silent_while_input_flows() -> None:
        if input_topic is not None:
            seen = got['in']
            assert ros.spin_until(lambda: got['in'] >= seen + INPUTS, timeout=60), f'{input_topic}: no input'
        else:
            ros.spin_for(3.0)   # nothing to count: a window of silence
        assert got['out'] == 0, f'{exe}: {got["out"]} messages on {output} while not active'

    # unconfigured: the services answer, no endpoint and no core
    assert manager.state() == 'unconfigured'
    assert node.count_publishers(output) == 0 and not node._lc_made['pub']
    silent_while_input_flows()
    # configure: the endpoints exist, nothing is published
    assert manager.set(Transition.TRANSITION_CONFIGURE)
    assert manager.state() == 'inactive'
    assert ros.spin_until(lambda: sink.count_publishers(output) >= 1, timeout=30)
    silent_while_input_flows()
    # activate: the estimator works
    assert manager.set(Transition.TRANSITION_ACTIVATE)
    assert manager.state() == 'active'
    assert ros.spin_until(lambda: got['out'] >= 2, timeout=120), f'{exe}: nothing on {output} once active'
    # deactivate: silent again (a message in flight may still land), input still flowing
    assert manager.set(Transition.TRANSITION_DEACTIVATE)
    assert manager.state() == 'inactive'
    if input_topic is not None:
        seen = got['in']
        assert ros.spin_until(lambda: got['in'] >= seen + 2, timeout=60)
    else:
        ros.spin_for(1.0)
    settled = got['out']
    got['out'] = 0
    silent_while_input_flows()
    got['out'] = settled
    # cleanup: the endpoints go, setup()'s attributes too; a second configure starts afresh
    assert manager.set(Transition.TRANSITION_CLEANUP)
    assert manager.state() == 'unconfigured'
    assert ros.spin_until(lambda: sink.count_publishers(output) == 0, timeout=30)
    assert {k for k in vars(node) if not k.startswith('_lc_')} == constructed   # setup()'s attributes gone
    assert manager.set(Transition.TRANSITION_CONFIGURE) and manager.set(Transition.TRANSITION_ACTIVATE)
    before = got['out']
    assert ros.spin_until(lambda: got['out'] >= before + 2, timeout=120), f'{exe}: nothing after a re-configure'
    assert manager.state() == 'active'


def test_a_configure_that_fails_leaves_the_node_unconfigured(ros):
    """fusion with no track topic refuses at setup(): the transition fails, the node stays unconfigured."""
    node = ros.add(node_class('lifecycle_fusion')(context=ros.context))
    manager = Manager(ros, node.get_name())
    assert not manager.set(Transition.TRANSITION_CONFIGURE)
    assert manager.state() == 'unconfigured'
    assert not node._lc_made['pub'] and node.count_publishers(FUSION_SCORES) == 0
    states = manager._call(manager.node.create_client(GetAvailableStates, f'/{node.get_name()}/get_available_states'),
                           GetAvailableStates.Request()).available_states
    assert {s.label for s in states} >= {'unconfigured', 'inactive', 'active', 'finalized'}
