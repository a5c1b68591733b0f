"""``sonar_observer``'s "no truth" warning runs on the node's clock (sim time under use_sim_time).

The check is called on a stand-in for the node (no rclpy.init, no DDS): its clock is an rclpy
``ROSClock`` driven like ``/clock``, and the wall clock (``steady_now``) fails if it is read.
"""

from __future__ import annotations

import inspect
from types import SimpleNamespace

from rclpy.clock import ROSClock
from rclpy.time import Time

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
                           sub_truth=SimpleNamespace(topic_name='/sonar/target/truth'))
    node._clock_s = lambda: SonarObserverNode._clock_s(node)
    node.last_truth = node._clock_s() or None
    return node, clock, log


def _at(clock: ROSClock, t: float) -> None:
    clock.set_ros_time_override(Time(nanoseconds=round(t * 1e9)))


def test_a_slow_run_whose_truths_come_every_sim_second_never_warns():
    node, clock, log = _node(EPOCH)
    for k in range(1, 40):  # whatever wall time passes between the steps: only the sim clock counts
        _at(clock, EPOCH + k)
        node.last_truth = node._clock_s()  # what _on_truth does
        SonarObserverNode._check_waiting(node)
    assert log.warnings == []


def test_ten_sim_seconds_without_a_truth_warn():
    node, clock, log = _node(EPOCH)
    _at(clock, EPOCH + WAIT_WARN - 0.5)
    SonarObserverNode._check_waiting(node)
    assert log.warnings == []
    _at(clock, EPOCH + WAIT_WARN)
    SonarObserverNode._check_waiting(node)
    assert len(log.warnings) == 1 and 'no truth on /sonar/target/truth for 10 s' in log.warnings[0]


def test_the_first_clock_after_start_is_not_ten_seconds_of_waiting():
    """Created before /clock (ROS time 0), the node starts waiting at the first sim time, not at 0."""
    node, clock, log = _node(0.0)
    assert node.last_truth is None
    SonarObserverNode._check_waiting(node)  # no /clock yet
    _at(clock, EPOCH)  # the first /clock: the overdue timer fires at once
    SonarObserverNode._check_waiting(node)
    assert log.warnings == [] and node.last_truth == EPOCH
    _at(clock, EPOCH + WAIT_WARN)
    SonarObserverNode._check_waiting(node)
    assert len(log.warnings) == 1


def test_the_wait_timer_is_on_the_node_clock():
    src = inspect.getsource(SonarObserverNode.setup)
    line = next(ln for ln in src.splitlines() if '_check_waiting' in ln)
    assert 'create_timer' in line and '_steady' not in line, line
