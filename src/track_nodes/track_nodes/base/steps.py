"""``FixedRateSteps``: a seeded simulator's step clock, reproducible whatever the executor timing."""

from __future__ import annotations

import math
from collections.abc import Callable

from rclpy.node import Node


class FixedRateSteps:
    """Call ``step(t)`` once per ``period`` of node time, at t = origin + k·period exactly.

    Stamps come from the step counter, not from when the timer happened to fire, and a late
    timer catches up one step at a time, so a seeded simulator publishes the same payloads
    whatever the executor timing. Under ``use_sim_time`` the origin is 0 (the launcher's
    clock starts there); on wall time it is the whole second at the first tick, unless the node
    fixes it (``origin``) and tells the others (``vehicle_sim`` stamps its layout with it).
    ``max_time`` > 0 stops stepping after that much node time since the origin.
    ``set_period`` (a live ``period`` parameter) keeps the steps taken: the next one comes one new
    period after the last.
    """

    def __init__(self, node: Node, period: float, step: Callable[[float], None], max_time: float = 0.0,
                 origin: float | None = None) -> None:
        self.node, self.period, self.step, self.max_time = node, period, step, max_time
        self.k = 0
        self.origin: float | None = origin  # None: fixed at the first tick (see above)
        self.offset = 0.0  # node time from the origin to step 0 of the current period
        self.timer = node.create_timer(period, self._tick)

    def set_period(self, period: float) -> None:
        if self.origin is not None:
            self.offset += self.k * self.period
            self.k = 0
        self.period = period
        self.timer.timer_period_ns = round(period * 1e9)

    def _tick(self) -> None:
        now = self.node.get_clock().now().nanoseconds * 1e-9
        if self.origin is None:
            self.origin = 0.0 if self.node.get_parameter('use_sim_time').value else float(math.floor(now))
        while self.origin + self.offset + (self.k + 1) * self.period <= now + 1e-9:
            if self.max_time > 0 and self.offset + (self.k + 1) * self.period > self.max_time + 1e-9:
                return
            self.k += 1
            self.step(self.origin + self.offset + self.k * self.period)
