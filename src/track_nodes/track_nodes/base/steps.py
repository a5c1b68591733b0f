"""``FixedRateSteps``: a seeded simulator's step clock, reproducible whatever the executor timing."""

from __future__ import annotations

from collections.abc import Callable

from rclpy.node import Node

NS = 1_000_000_000
PROBE = 1e-3  # node seconds after start at which the origin is read


class FixedRateSteps:
    """Call ``step(t)`` once per ``period`` of node time, at t = origin + k·period exactly.

    Stamps come from the step counter, not from when the timer happened to fire, and a late
    timer catches up one step at a time, so a seeded simulator publishes the same payloads
    whatever the executor timing. The origin is the whole second of node time when the node's
    clock first runs (read by a 1 ms probe timer: under ``use_sim_time`` at the first ``/clock``,
    and the launcher's clock starts at a whole second, its ``--epoch``), unless the node fixes it
    (``origin``) and tells the others (``vehicle_sim`` stamps its layout with it);
    ``on_origin(origin)`` is called once when it is fixed.
    Due times are compared in integer nanoseconds: at epoch seconds (~1.8e9) a float second has a
    resolution of 2.4e-7 s, too coarse for a 1 ns tolerance. ``max_time`` > 0 stops stepping
    after that much node time since the origin. ``set_period`` (a live ``period`` parameter) keeps
    the steps taken: the next one comes one new period after the last.
    """

    def __init__(self, node: Node, period: float, step: Callable[[float], None], max_time: float = 0.0,
                 origin: float | None = None, on_origin: Callable[[float], None] | None = None) -> None:
        self.node, self.period, self.step, self.max_time = node, period, step, max_time
        self.on_origin = on_origin
        self.k = 0
        self.origin: float | None = origin  # None: fixed at the first tick (see above)
        self.offset = 0.0  # node time from the origin to step 0 of the current period
        self.timer = node.create_timer(period, self._tick)
        # The origin is the clock's first reading, not the first step's: a 1 ms probe fixes it.
        self._probe = node.create_timer(PROBE, self._fix_origin) if origin is None else None

    def set_period(self, period: float) -> None:
        if self.origin is not None:
            self.offset += self.k * self.period
            self.k = 0
        self.period = period
        self.timer.timer_period_ns = round(period * 1e9)

    def _due_ns(self, k: int) -> int:
        """Node time of step k since the origin [ns]."""
        return round((self.offset + k * self.period) * NS)

    def _fix_origin(self) -> None:
        if self._probe is not None:
            self.node.destroy_timer(self._probe)
            self._probe = None
        if self.origin is None:
            self.origin = float(self.node.get_clock().now().nanoseconds // NS)
            if self.on_origin is not None:
                self.on_origin(self.origin)

    def _tick(self) -> None:
        now_ns = self.node.get_clock().now().nanoseconds
        if self.origin is None:
            self._fix_origin()
        origin_ns = round(self.origin * NS)
        max_ns = round(self.max_time * NS)
        while origin_ns + self._due_ns(self.k + 1) <= now_ns:
            if max_ns > 0 and self._due_ns(self.k + 1) > max_ns:
                return
            self.k += 1
            self.step(self.origin + self.offset + self.k * self.period)
