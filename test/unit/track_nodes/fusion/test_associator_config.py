"""``AssociatorConfig``: the fusion node declares the core's defaults under its own parameter names, and
the node, the offline replay and the benches build their associator from one config."""

import dataclasses

import pytest
from rclpy.parameter import Parameter

from track_core.fusion import AssociatorConfig, PairAssociator
from track_nodes.base import ParameterError
from track_nodes.base.params import all_specs
from track_nodes.fusion.fusion import FusionNode
from track_nodes.fusion.params import RENAMED, FusionParams, associator_config
from track_nodes.report import network_replay

# What a live run used before the config existed (the node's declared defaults): they must not move.
LIVE_DEFAULTS = {'method': 'exact', 'threshold': 0.5, 'combine': 'geometric', 'window': 10, 'floor': 0.0,
                 'release_ratio': 1.0, 'prior_weight': 0.0, 'prior_score': 1.0, 'n_samples': 500, 'seed': 0,
                 'same_source_pairs': False, 'stale_after': 2.0, 'max_prediction': 10.0, 'q_s': 0.1,
                 'stamps_max_wait': 30.0, 'schedule': 'timer', 'rate': 2.0}


def test_the_node_declares_the_core_defaults_under_its_parameter_names():
    declared = {s.name: s.default for s in all_specs(FusionParams)}
    core = AssociatorConfig()
    for f in dataclasses.fields(AssociatorConfig):
        if f.name in ('gate', 'stamp_rate'):        # not a parameter; from schedule and rate
            continue
        name = RENAMED.get(f.name, f.name)
        assert declared[name] == getattr(core, f.name) and type(declared[name]) is type(getattr(core, f.name)), name
    assert {k: declared[k] for k in LIVE_DEFAULTS} == LIVE_DEFAULTS
    assert all(type(declared[k]) is type(v) for k, v in LIVE_DEFAULTS.items())   # ROS types unchanged
    assert associator_config({}) == core == associator_config(FusionParams())
    assert associator_config({'schedule': 'stamps'}).stamp_rate == 2.0


def test_the_node_and_the_replay_build_one_associator_from_the_scenario_file(ros, repo):
    scenario = repo / 'config/maritime.yaml'
    node = ros.add(FusionNode(node_name='fusion', context=ros.context,
                              cli_args=['--ros-args', '--params-file', str(scenario)]))
    replay = network_replay.fusion_config(**network_replay.fusion_of(scenario))
    assert node.core.config == replay
    assert (replay.window, replay.floor, replay.stamp_rate, replay.q_s) == (15, 0.1353352832366127, 1.0, 1.0)
    assert node.core.schedule.streams == ('/sonar/estimate', '/idsq/estimate', '/radar/t0')
    with pytest.raises(ValueError, match='schedule: stamps'):   # the replay cannot score at node-clock ticks
        network_replay.fusion_config(**{**network_replay.fusion_of(scenario), 'schedule': 'timer'})


def test_a_live_change_retunes_the_core_and_its_config(ros):
    node = ros.add(FusionNode(node_name='fusion', context=ros.context,
                              parameter_overrides=[Parameter('pose_topics', value=['/a'])]))
    res = node.set_parameters([Parameter('threshold', value=0.8), Parameter('stale_after', value=3.0)])
    assert all(r.successful for r in res)
    assert node.core.threshold == 0.8 and node.core.table.stale_after == 3.0
    assert node.core.config == dataclasses.replace(AssociatorConfig(), threshold=0.8, stale_after=3.0)


@pytest.mark.parametrize(('values', 'name'), [
    ({'window': 0}, 'window'), ({'method': 'bogus'}, 'method'), ({'floor': 1.0}, 'floor'),
    ({'prior_score': 0.0}, 'prior_score'), ({'stale_after': -1.0}, 'stale_after'), ({'sead': 1}, 'sead'),
])
def test_a_bad_value_is_one_parameter_error_line(values, name):
    with pytest.raises(ParameterError) as exc:
        associator_config(values)
    assert name in str(exc.value) and '\n' not in str(exc.value)


def test_a_bad_value_stops_the_node_with_one_line(ros):
    with pytest.raises(ParameterError) as exc:
        FusionNode(context=ros.context, parameter_overrides=[Parameter('window', value=0),
                                                             Parameter('pose_topics', value=['/a'])])
    assert 'window' in str(exc.value) and '\n' not in str(exc.value)


@pytest.mark.parametrize(('field', 'value'), [
    ('method', 'x'), ('threshold', 1.5), ('combine', 'x'), ('window', 0), ('window', 2.5), ('floor', 1.0),
    ('release_ratio', 0.0), ('prior_weight', -1.0), ('prior_score', 2.0), ('n_samples', 0), ('seed', -1),
    ('stale_after', 0.0), ('max_prediction', float('nan')), ('q_s', -0.1), ('stamp_rate', 0.0),
    ('stamp_max_wait', -1.0),
])
def test_the_core_config_names_the_bad_field(field, value):
    with pytest.raises(ValueError, match=f'^{field} ') as exc:
        AssociatorConfig(**{field: value})
    assert '\n' not in str(exc.value)


def test_the_associator_takes_the_config_or_its_fields():
    cfg = AssociatorConfig(threshold=0.3, window=4, stale_after=1.5)
    assert PairAssociator(cfg).config == cfg
    assert PairAssociator('exact', 0.3, 'geometric', 4, stale_after=1.5).config == cfg   # the older call
    assert PairAssociator(cfg, window=5).config == dataclasses.replace(cfg, window=5)
