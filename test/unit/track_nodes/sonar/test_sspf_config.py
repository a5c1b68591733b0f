"""``SSPFConfig`` and ``SchedulerConfig``: ``sonar_observer`` declares the core's defaults under its own
parameter names and builds its tracker from the configs, as the maritime replay does."""

import dataclasses

import numpy as np
import pytest
from rclpy.parameter import Parameter

from track_core.sonar import SchedulerConfig, SmartTargetParams, SonarParams, SSPFConfig, make_tracker
from track_nodes.base import ParameterError
from track_nodes.base.params import all_specs
from track_nodes.report.maritime_sim import sections
from track_nodes.sonar.observer_params import (
    SonarObserverParams,
    observer_tracker,
    p_d,
    scheduler_config,
    sonar_params,
    sspf_config,
    target_model_of,
)
from track_nodes.sonar.sonar_observer import SonarObserverNode

# What a live run used before the configs existed (the node's declared defaults): they must not move.
LIVE_DEFAULTS = {'tracker': 'ss-pf', 'delta': 5.0, 'P_D': [5.0, 0.25, 5.0, 0.25], 'metric': 'spectral',
                 'initial_pings': 1, 'prediction': 'unscented', 'regularize': True, 'n_particles': 200,
                 'period': 1.0, 'q_s': 1.0, 'target_model': 'cv'}


def _params(section: dict) -> SonarObserverParams:
    names = {f.name for f in dataclasses.fields(SonarObserverParams)}
    return SonarObserverParams(**{k: v for k, v in section.items() if k in names})


def test_the_node_declares_the_core_defaults_under_its_parameter_names():
    declared = {s.name: s.default for s in all_specs(SonarObserverParams)}
    sched, sspf, sonar = SchedulerConfig(), SSPFConfig(), SonarParams()
    assert {k: declared[k] for k in LIVE_DEFAULTS} == LIVE_DEFAULTS
    assert all(type(declared[k]) is type(v) for k, v in LIVE_DEFAULTS.items())   # ROS types unchanged
    assert (declared['delta'], declared['P_D'], declared['metric'], declared['initial_pings']) == (
        sched.delta, list(sched.P_D), sched.metric, sched.initial_pings)
    assert (declared['prediction'], declared['regularize']) == (sspf.prediction, sspf.regularize)
    assert (declared['n_particles'], declared['period'], declared['q_s']) == (sonar.n_particles, sonar.T, sonar.q_s)
    p = SonarObserverParams()
    assert (sspf_config(p), scheduler_config(p), sonar_params(p)) == (sspf, sched, sonar)


def test_the_node_and_the_replay_build_one_tracker_from_the_scenario_file(ros, repo):
    scenario = repo / 'config/maritime.yaml'
    node = ros.add(SonarObserverNode(node_name='sonar_observer', context=ros.context,
                                     cli_args=['--ros-args', '--params-file', str(scenario)]))
    op = _params(sections(scenario)['sonar_observer'])
    sonar = sonar_params(op)
    ours = observer_tracker(op, sonar, np.random.default_rng(0))
    assert node.tracker.config == ours.config and node.tracker.scheduler.config == ours.scheduler.config
    assert ours.config.target_model == target_model_of(op) and ours.config.prediction == 'linear'
    assert ours.scheduler.config == SchedulerConfig(delta=50.0, initial_pings=2)
    # the replay's call (report.maritime_sim) with the parameters one by one: the same tracker, the same draws
    legacy = make_tracker(op.tracker, sonar, np.random.default_rng(0), P_D=p_d(op.P_D), delta=op.delta,
                          metric=op.metric, regularize=op.regularize, initial_pings=op.initial_pings,
                          target_model=target_model_of(op), prediction=op.prediction)
    assert legacy.config == ours.config and legacy.scheduler.config == ours.scheduler.config
    prior = np.diag([400.0, 4.0, 400.0, 4.0])
    for trk in (ours, legacy):
        trk.initialize(np.asarray(op.prior_mean, dtype=float), prior)
        trk.step(np.array([0.3, 200.0]), 'active', np.zeros(2))
    np.testing.assert_array_equal(ours.estimate.mean, legacy.estimate.mean)
    np.testing.assert_array_equal(ours.estimate.cov, legacy.estimate.cov)


@pytest.mark.parametrize(('overrides', 'name'), [
    ({'P_D': [5.0, 0.25, 5.0]}, 'P_D'),
    ({'P_D': [1.0, 2.0] + [0.0] * 14}, 'P_D'),      # not symmetric
    ({'delta': -1.0}, 'delta'),
    ({'initial_pings': 0}, 'initial_pings'),
])
def test_a_bad_value_stops_the_node_with_one_parameter_error_line(ros, overrides, name):
    with pytest.raises(ParameterError) as exc:
        SonarObserverNode(context=ros.context,
                          parameter_overrides=[Parameter(k, value=v) for k, v in overrides.items()])
    assert name in str(exc.value) and '\n' not in str(exc.value)


def test_the_mapping_names_the_parameter_of_a_core_refusal():
    bad = dataclasses.replace(SonarObserverParams(), target_model='smart', model_r_50=-1.0)
    with pytest.raises(ParameterError, match=r'^parameter model_r_50 ') as exc:
        sspf_config(bad)
    assert '\n' not in str(exc.value)
    with pytest.raises(ParameterError, match=r'^parameter period '):
        sonar_params(dataclasses.replace(SonarObserverParams(), period=0.0))


@pytest.mark.parametrize(('cls', 'field', 'value'), [
    (SchedulerConfig, 'delta', float('nan')), (SchedulerConfig, 'metric', 'frobenius'),
    (SchedulerConfig, 'block', 'velocity'), (SchedulerConfig, 'cov_kind', 'x'), (SchedulerConfig, 'initial_pings', 1.5),
    (SchedulerConfig, 'P_D', (1.0, 2.0, 3.0)), (SSPFConfig, 'proposal', 'x'), (SSPFConfig, 'resample_threshold', 0.0),
    (SSPFConfig, 'split', 2.0), (SSPFConfig, 'move_threshold', 0.0), (SSPFConfig, 'prior_inflation', 0.5),
    (SSPFConfig, 'prediction', 'ekf'),
])
def test_the_core_configs_name_the_bad_field(cls, field, value):
    with pytest.raises(ValueError, match=f'^{field}') as exc:
        cls(**{field: value})
    assert '\n' not in str(exc.value)


def test_a_smart_model_needs_the_rb_proposal_and_p_d_has_one_form():
    with pytest.raises(ValueError, match=r"^target_model needs proposal='rb'"):
        SSPFConfig(proposal='transition', target_model=SmartTargetParams())
    m = np.diag([1.0, 2.0, 3.0, 4.0])
    assert SchedulerConfig(P_D=m) == SchedulerConfig(P_D=m.ravel()) == SchedulerConfig(P_D=[1.0, 2.0, 3.0, 4.0])
    m[0, 2] = m[2, 0] = 0.5
    assert tuple(m.ravel()) == SchedulerConfig(P_D=m).P_D and np.array_equal(SchedulerConfig(P_D=m).P_D_matrix, m)
    assert SchedulerConfig(P_D=None) == SchedulerConfig()
