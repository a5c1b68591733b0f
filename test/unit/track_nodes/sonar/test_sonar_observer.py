"""``sonar_observer``: the "no contact" warning runs on the node's clock (sim time under use_sim_time);
the target model of its parameters (``target_model_of``), as the node and the maritime replay use it.

The check is called on a stand-in for the node (no rclpy.init, no DDS): its clock is an rclpy
``ROSClock`` driven like ``/clock``, and the wall clock (``steady_now``) fails if it is read.
"""

from __future__ import annotations

import dataclasses
import inspect
import math
from types import SimpleNamespace

import numpy as np
import pytest
from rclpy.clock import ROSClock
from rclpy.time import Time

from track_core.sonar import SmartTargetParams
from track_nodes.idsq.scenario_files import seed_scenario
from track_nodes.report.maritime import SONAR_TRACK
from track_nodes.report.maritime_sim import sections, simulate
from track_nodes.sonar.observer_params import SonarObserverParams, target_model_of
from track_nodes.sonar.sonar_observer import WAIT_WARN, SonarObserverNode

EPOCH = 1796283180.0


class _Logger:
    def __init__(self):
        self.warnings: list[str] = []

    def warning(self, line: str, **_) -> None:
        self.warnings.append(line)


def _node(sim_time: float):
    clock = ROSClock()
    clock._set_ros_time_is_active(True)  # as under use_sim_time
    clock.set_ros_time_override(Time(nanoseconds=round(sim_time * 1e9)))
    log = _Logger()

    def wall():
        raise AssertionError('the wait check read the wall clock')

    node = SimpleNamespace(get_clock=lambda: clock, get_logger=lambda: log, steady_now=wall,
                           sub_contact=SimpleNamespace(topic_name='/sonar/contacts'))
    node._clock_s = lambda: SonarObserverNode._clock_s(node)
    node.last_contact = node._clock_s() or None
    return node, clock, log


def _at(clock: ROSClock, t: float) -> None:
    clock.set_ros_time_override(Time(nanoseconds=round(t * 1e9)))


def test_a_slow_run_whose_contacts_come_every_sim_second_never_warns():
    node, clock, log = _node(EPOCH)
    for k in range(1, 40):  # whatever wall time passes between the steps: only the sim clock counts
        _at(clock, EPOCH + k)
        node.last_contact = node._clock_s()  # what _on_contact does
        SonarObserverNode._check_waiting(node)
    assert log.warnings == []


def test_ten_sim_seconds_without_a_contact_warn():
    node, clock, log = _node(EPOCH)
    _at(clock, EPOCH + WAIT_WARN - 0.5)
    SonarObserverNode._check_waiting(node)
    assert log.warnings == []
    _at(clock, EPOCH + WAIT_WARN)
    SonarObserverNode._check_waiting(node)
    assert len(log.warnings) == 1 and 'no contact on /sonar/contacts for 10 s' in log.warnings[0]


def test_the_first_clock_after_start_is_not_ten_seconds_of_waiting():
    """Created before /clock (ROS time 0), the node starts waiting at the first sim time, not at 0."""
    node, clock, log = _node(0.0)
    assert node.last_contact is None
    SonarObserverNode._check_waiting(node)  # no /clock yet
    _at(clock, EPOCH)  # the first /clock: the overdue timer fires at once
    SonarObserverNode._check_waiting(node)
    assert log.warnings == [] and node.last_contact == EPOCH
    _at(clock, EPOCH + WAIT_WARN)
    SonarObserverNode._check_waiting(node)
    assert len(log.warnings) == 1


def test_the_wait_timer_is_on_the_node_clock():
    src = inspect.getsource(SonarObserverNode.setup)
    line = next(ln for ln in src.splitlines() if '_check_waiting' in ln)
    assert 'create_timer' in line and '_steady' not in line, line


def test_the_cv_target_model_is_the_default_and_gives_no_model():
    assert SonarObserverParams().target_model == 'cv'
    assert target_model_of(SonarObserverParams()) is None


def test_the_smart_target_model_takes_the_model_parameters():
    p = SonarObserverParams(target_model='smart', model_evade_speed=9.0, model_max_turn_rate_deg=6.0,
                            model_quiet_period=4.0)
    tm = target_model_of(p)
    assert tm == SmartTargetParams(evade_speed=9.0, max_turn_rate=math.radians(6.0), quiet_period=4.0)
    # the defaults are the core's, so an unset model_* is SmartTargetParams' default (the turn rate via degrees)
    default = target_model_of(SonarObserverParams(target_model='smart'))
    assert default.max_turn_rate == pytest.approx(SmartTargetParams().max_turn_rate, rel=1e-12)
    assert dataclasses.replace(default, max_turn_rate=SmartTargetParams().max_turn_rate) == SmartTargetParams()


def test_the_maritime_observer_models_the_maritime_target(repo):
    """config/maritime.yaml: the observer's model_* are the smart_target's own parameters."""
    sec = sections(repo / 'src/track_nodes/config/maritime.yaml')
    obs, tgt = sec['sonar_observer'], sec['smart_target']
    assert obs['target_model'] == 'smart'
    for key in ('p_max', 'r_50', 'width', 'evade_speed', 'max_turn_rate_deg', 'max_accel', 'quiet_period'):
        assert obs[f'model_{key}'] == tgt[key], key


def test_the_replay_runs_the_observer_with_its_target_model():
    """``maritime_sim`` gives the observer the node's target model: cv and smart give other tracks."""
    cfg = seed_scenario(1)
    node = cfg['/**/sonar_observer']['ros__parameters']
    runs = {}
    for model in ('cv', 'smart'):
        node['target_model'] = model
        runs[model] = simulate(cfg, n_steps=6)['tracks'][SONAR_TRACK][1]
    assert not np.allclose(runs['cv'], runs['smart'])
