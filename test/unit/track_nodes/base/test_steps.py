"""base/steps.py: a step stamped t goes out at t, not up to a period later (the timer is put on the step grid)."""

from __future__ import annotations

from rclpy.node import Node

from track_nodes.base.steps import NS, PHASE_TOLERANCE, FixedRateSteps

PERIOD = 0.4  # [s] on wall time: the node clock is the system clock


def _grid_phase_ns(steps: FixedRateSteps, node: Node) -> int:
    """How far the periodic timer's next call lies from the step grid, in ns (0: on it)."""
    due = node.get_clock().now().nanoseconds + steps.timer.time_until_next_call() - round(steps.origin * NS)
    off = due % round(steps.period * NS)
    return min(off, round(steps.period * NS) - off)


def test_the_timer_runs_on_the_step_grid_whatever_its_start(ros):
    """Built at an arbitrary instant of wall time, the steps come out at their stamps: from the first due
    step on, the periodic timer is in phase with origin + k·period (both readings are taken back to back)."""
    node = ros.add(Node('steps_probe', context=ros.context))
    stamps: list[float] = []
    steps = FixedRateSteps(node, PERIOD, stamps.append)
    assert ros.spin_until(lambda: len(stamps) >= 2, timeout=120), stamps
    assert _grid_phase_ns(steps, node) <= (PHASE_TOLERANCE + 0.02) * NS
    assert stamps == [steps.origin + k * PERIOD for k in range(1, len(stamps) + 1)]   # every step, in order


def test_a_given_origin_is_aligned_at_the_first_tick(ros):
    """An origin fixed by the node (vehicle_sim's layout stamp) has no probe: the first tick re-phases."""
    node = ros.add(Node('steps_given', context=ros.context))
    origin = float(node.get_clock().now().nanoseconds // NS)
    stamps: list[float] = []
    steps = FixedRateSteps(node, PERIOD, stamps.append, origin=origin)
    assert ros.spin_until(lambda: len(stamps) >= 4, timeout=120), stamps
    assert _grid_phase_ns(steps, node) <= (PHASE_TOLERANCE + 0.02) * NS
    assert all(abs((t - origin) / PERIOD - round((t - origin) / PERIOD)) < 1e-6 for t in stamps)
