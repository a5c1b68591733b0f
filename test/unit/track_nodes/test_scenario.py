import pytest

from track_nodes.launch.scenario import ScenarioError, load_scenario


def test_demo_scenario_lists_its_nodes(repo):
    sc = load_scenario(str(repo / 'config/demo.yaml'))
    assert [(n.executable, n.name) for n in sc.nodes] == [('demo_target', 'demo_target'),
                                                          ('demo_tracker', 'demo_tracker')]
    assert sc.options['summary'] == 'demo'


def test_executable_with_node_name(tmp_path):
    f = tmp_path / 's.yaml'
    f.write_text('track_launch:\n  ros__parameters:\n    nodes: [demo_target:a, demo_target:b]\n')
    assert [n.name for n in load_scenario(str(f)).nodes] == ['a', 'b']


@pytest.mark.parametrize(('text', 'words'), [
    ('demo_target:\n  ros__parameters: {}\n', 'needs track_launch'),
    ('track_launch:\n  ros__parameters:\n    nodes: [x, x]\n', 'unique'),
    ('track_launch: [\n', 'cannot read'),
])
def test_bad_scenarios_are_named(tmp_path, text, words):
    f = tmp_path / 'bad.yaml'
    f.write_text(text)
    with pytest.raises(ScenarioError, match=words):
        load_scenario(str(f))


def test_missing_scenario():
    with pytest.raises(ScenarioError, match='not found'):
        load_scenario('no_such_scenario')


def test_unknown_executable(tmp_path):
    f = tmp_path / 's.yaml'
    f.write_text('track_launch:\n  ros__parameters:\n    nodes: [nope]\n')
    with pytest.raises(ScenarioError, match='unknown node executable'):
        load_scenario(str(f)).nodes[0].node_class()


def test_every_scenario_file_is_a_valid_params_file(ros, repo):
    """rcl's own YAML parser accepts each config (e.g. unquoted 'exe:name' in a flow list breaks it)."""
    from rclpy.node import Node

    configs = sorted((repo / 'config').glob('*.yaml'))
    assert configs
    for cfg in configs:
        node = Node('track_launch', context=ros.context, cli_args=['--ros-args', '--params-file', str(cfg)],
                    automatically_declare_parameters_from_overrides=True)
        assert node.get_parameter('nodes').value, cfg.name
        node.destroy_node()
