"""Unknown parameter names are refused: a typo in ``-p``, a params file or ``parameter_overrides`` stops
the node with one line naming the closest declared parameters, instead of running on defaults."""

from __future__ import annotations

import subprocess

import pytest
from rclpy.parameter import Parameter

from track_nodes.base import ParameterError
from track_nodes.demo.demo_target import DemoTargetNode
from track_nodes.slam.slam import SlamNode
from track_nodes.slam.slam_sim import SlamSimNode

pytestmark = pytest.mark.integration


def _params(tmp_path, text: str) -> list[str]:
    path = tmp_path / 'p.yaml'
    path.write_text(text)
    return ['--ros-args', '--params-file', str(path)]


def _build(ros, cls, **kw):
    node = cls(context=ros.context, **kw)
    ros.add(node)
    return node


def _drop(ros, node) -> None:
    """Destroy ``node`` now: the next build of its name would be a twin (base/ready.py)."""
    ros.nodes.remove(node)
    ros.executor.remove_node(node)
    node.destroy_node()


@pytest.mark.parametrize(('kw', 'typo', 'meant'), [
    ({'cli_args': ['--ros-args', '-p', 'perod:=0.5']}, 'perod', 'period'),
    ({'cli_args': ['--ros-args', '-p', 'demo_target:sead:=3']}, 'sead', 'seed'),
    ({'parameter_overrides': [Parameter('sigma_rr', value=2.0)]}, 'sigma_rr', 'sigma_r'),
])
def test_a_misspelt_parameter_is_refused_with_the_closest_names(ros, kw, typo, meant):
    with pytest.raises(ParameterError) as exc:
        _build(ros, DemoTargetNode, **kw)
    line = str(exc.value)
    assert '\n' not in line and repr(typo) in line and meant in line and '/demo_target' in line, line


def test_params_file_sections_of_this_node_are_checked_and_the_others_left_alone(ros, tmp_path):
    shared = ('/**:\n  ros__parameters:\n    use_sim_time: false\n    only_some_nodes_have_it: 1\n'
              '    qos_overrides:\n      /demo/truth:\n        publisher:\n          depth: 3\n'
              'demo_tracker:\n  ros__parameters:\n    not_ours: 1\n'
              '/other_ns/demo_target:\n  ros__parameters:\n    not_ours_either: 1\n'
              'demo_target:\n  ros__parameters:\n    seed: 4\n    start_type_description_service: true\n')
    node = _build(ros, DemoTargetNode, cli_args=_params(tmp_path, shared))
    assert node.p.seed == 4
    _drop(ros, node)
    with pytest.raises(ParameterError, match=r"'sead' \(did you mean seed\?\)"):
        _build(ros, DemoTargetNode, cli_args=_params(tmp_path, shared + '    sead: 3\n'))
    namespaced = '/ns/demo_target:\n  ros__parameters:\n    sead: 3\n'
    with pytest.raises(ParameterError, match=r"'sead'.*for node /ns/demo_target"):
        _build(ros, DemoTargetNode, namespace='ns', cli_args=_params(tmp_path, namespaced))
    nested = 'ns:\n  demo_target:\n    ros__parameters:\n      sead: 3\n'
    with pytest.raises(ParameterError, match="'sead'"):
        _build(ros, DemoTargetNode, namespace='ns', cli_args=_params(tmp_path, nested))


def test_parameters_declared_in_setup_from_a_dataclass_are_known(ros, tmp_path):
    """slam and slam_sim declare a core dataclass as ``<prefix>.<field>`` parameters (``group``): those are valid."""
    node = _build(ros, SlamSimNode, cli_args=_params(tmp_path, 'slam_sim:\n  ros__parameters:\n    world.dt: 0.1\n'))
    assert node.world.dt == 0.1
    _drop(ros, node)
    with pytest.raises(ParameterError, match=r"'world\.dtt' \(did you mean world\.dt"):
        _build(ros, SlamSimNode, parameter_overrides=[Parameter('world.dtt', value=0.1)])


def _slam_params():
    from track_core.slam.profiles import VICTORIA_PARK
    from track_nodes.base.params import dataclass_params

    groups = {'cekf': VICTORIA_PARK.slam, 'pf': VICTORIA_PARK.pf, 'hybrid': VICTORIA_PARK.hybrid}
    return [p for prefix, default in groups.items() for p in dataclass_params(prefix, default)]


def test_the_core_parameters_of_slam_are_accepted_by_name(ros):
    given = [Parameter(p.name, value=p.default) for p in _slam_params()]
    node = _build(ros, SlamNode, parameter_overrides=given)
    assert all(node.has_parameter(p.name) for p in given)


def test_a_node_process_refuses_a_typo_in_one_line_with_exit_code_2(prefix, env_factory):
    proc = subprocess.Popen([str(prefix / 'lib/track_nodes/demo_target'), '--ros-args', '-p', 'sead:=3'],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env=env_factory())
    try:
        _, err = proc.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        proc.kill()
        pytest.fail('demo_target ran with an unknown parameter')
    lines = err.strip().splitlines()
    assert proc.returncode == 2 and len(lines) == 1 and 'Traceback' not in err, err
    assert lines[0].startswith('demo_target: unknown parameter') and 'seed' in lines[0], lines[0]


def test_the_player_declares_after_the_base_constructor_and_is_checked_after_it(ros, tmp_path):
    from rclpy.serialization import serialize_message
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore
    from std_msgs.msg import String

    from track_nodes.bag.player import PlayerNode

    bag = tmp_path / 'b'
    with Writer(bag, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        c = w.add_connection('/names/x', 'std_msgs/msg/String', typestore=get_typestore(Stores.ROS2_JAZZY))
        w.write(c, 1, serialize_message(String(data='a')))
    given = [Parameter('bag', value=str(bag)), Parameter('wait_subscribers', value=0.0)]
    player = _build(ros, PlayerNode, parameter_overrides=[*given, Parameter('rate', value=2.0)])
    assert player.p.rate == 2.0
    _drop(ros, player)
    with pytest.raises(ParameterError, match=r"'rat' \(did you mean rate\?\)"):
        _build(ros, PlayerNode, parameter_overrides=[*given, Parameter('rat', value=2.0)])


@pytest.mark.parametrize(('edit', 'words'), [
    (lambda t: t.replace('demo_tracker:\n', 'demo_trackr:\n'), ["node section 'demo_trackr'", 'demo_tracker']),
    (lambda t: t.replace('    q_s:', '    q_ss:'), ["'q_ss' (did you mean q_s?) for node /demo_target"]),
    (lambda t: t + '\n/**:\n  ros__parameters:\n    sead: 3\n', ["'sead'", 'under /**', 'seed']),
])
def test_the_launcher_refuses_a_misspelt_scenario_in_one_line(repo, tmp_path, env_factory, edit, words):
    import sys

    scenario = tmp_path / 'demo.yaml'
    scenario.write_text(edit((repo / 'config/demo.yaml').read_text()))
    proc = subprocess.run([sys.executable, '-m', 'track_nodes.launch', str(scenario), '--duration', '1'],
                          cwd=tmp_path, env=env_factory(), capture_output=True, text=True, timeout=120)
    errors = [line for line in proc.stderr.splitlines() if line.startswith('track_nodes.launch: ')]
    assert proc.returncode == 2 and len(errors) == 1 and 'Traceback' not in proc.stderr, proc.stderr
    assert all(w in errors[0] for w in words), errors[0]
