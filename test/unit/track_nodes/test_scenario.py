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


@pytest.mark.parametrize('seed', [1, 2, 3, 4, 5])
def test_maritime_radio_range_links_the_columns(seed):
    """``maritime_yaml``'s comm_range (60 m, the 99.9 % quantile of the distance between row neighbours in
    adjacent columns under the §5.1 jitter) links every such pair, which the §5.1 40 m does not (issue 17)."""
    import numpy as np
    import yaml

    from track_core.idsq.simulation import scenario_of
    from track_nodes.base.scenario_file import section_node
    from track_nodes.idsq.scenario_files import maritime_yaml

    cfg = yaml.safe_load(maritime_yaml(seed=seed))
    ranges = {v['ros__parameters']['comm_range'] for k, v in cfg.items() if section_node(k).startswith('sensor_')}
    assert ranges == {60.0}
    _, layout, _ = scenario_of(seed, 40, 0.3)
    rows = layout.positions.reshape(10, 4, 2)
    d = np.hypot(*(rows[:, 1:] - rows[:, :-1]).transpose(2, 0, 1))  # (10 rows, 3 column gaps)
    assert d.max() <= 60.0 and (d > 40.0).any()
    rng = np.random.default_rng(0)  # the 99.9 % quantile of that distance (columns 37.5 m apart, jitter N(0, 25 m²))
    e = rng.normal(0.0, np.sqrt(50.0), (200_000, 2))
    assert abs(np.quantile(np.hypot(37.5 + e[:, 0], e[:, 1]), 0.999) - 60.0) < 1.0


def test_maritime_fusion_release_is_one_disjoint_instant_below_the_threshold():
    """The maritime fusion's release ratio is ε^(1/(window + prior_weight)) (``associator.release_ratio_of``),
    so an association outlasts one disjoint instant, whatever the window, floor and prior the scenario sets."""
    import math

    import yaml

    from track_core.fusion.associator import release_ratio_of
    from track_nodes.base.scenario_file import section_node
    from track_nodes.idsq.scenario_files import maritime_yaml

    cfg = yaml.safe_load(maritime_yaml(seed=1))
    (f,) = [v['ros__parameters'] for k, v in cfg.items() if section_node(k) == 'fusion']
    assert math.isclose(f['release_ratio'], release_ratio_of(f['floor'], f['window'], f['prior_weight']),
                        rel_tol=1e-12)
    assert f['release_ratio'] < 1.0


@pytest.mark.parametrize(('extra', 'words'), [
    ('demo_trackr:\n  ros__parameters:\n    q_s: 1.0\n', ["node section 'demo_trackr' (did you mean demo_tracker"]),
    ('/ns/demo_tracker:\n  ros__parameters:\n    q_s: 1.0\n', ["'ns/demo_tracker'"]),
    ('/**/demo_trackr:\n  ros__parameters:\n    q_s: 1.0\n', ["'demo_trackr' (did you mean demo_tracker"]),
])
def test_a_section_for_no_node_of_the_scenario_is_refused(repo, tmp_path, extra, words):
    f = tmp_path / 'demo.yaml'
    f.write_text((repo / 'config/demo.yaml').read_text() + '\n' + extra)
    with pytest.raises(ScenarioError) as exc:
        load_scenario(str(f))
    assert all(w in str(exc.value) for w in words) and '\n' not in str(exc.value), exc.value


def test_wildcard_and_recorder_sections_are_for_every_scenario(repo, tmp_path):
    f = tmp_path / 'demo.yaml'
    f.write_text((repo / 'config/demo.yaml').read_text() + '\n/**:\n  ros__parameters:\n    use_sim_time: true\n'
                 'recorder:\n  ros__parameters:\n    regex: x\n/**/recorder:\n  ros__parameters:\n    regex: y\n')
    assert [n.name for n in load_scenario(str(f)).nodes] == ['demo_target', 'demo_tracker']


def test_an_unknown_launch_option_is_refused(repo, tmp_path):
    f = tmp_path / 'demo.yaml'
    f.write_text((repo / 'config/demo.yaml').read_text().replace('    duration:', '    duraton:'))
    with pytest.raises(ScenarioError, match=r"unknown track_launch option 'duraton' \(did you mean duration\?\)"):
        load_scenario(str(f))


def test_every_shipped_scenario_passes_the_name_check(repo):
    for cfg in sorted((repo / 'config').glob('*.yaml')):
        assert load_scenario(str(cfg)).nodes, cfg.name
