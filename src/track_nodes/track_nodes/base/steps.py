"""``FixedRateSteps``: a seeded simulator's step clock, reproducible whatever the executor timing."""

from __future__ import annotations

from collections.abc import Callable

from rclpy.node import Node

NS = 1_000_000_000
PROBE = 1e-3  # node seconds after start at which the origin is read
PHASE_TOLERANCE = 2e-3  # node seconds: a periodic timer this close to the step grid is left as it is


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

    The periodic timer starts when the node is built, at any phase of the step grid; on wall time a
    step stamped t would then go out up to a period after t (a report 1.9 s old when it leaves, at a
    2 s period). So once the origin is known the timer is re-phased onto the grid: a one-shot timer
    to the next due time, from which the periodic timer runs (``_align``). Under a ``/clock`` that
    starts at the origin the grid and the first phase agree and the schedule is the same as before.
    """

    def __init__(self, node: Node, period: float, step: Callable[[float], None], max_time: float = 0.0,
                 origin: float | None = None, on_origin: Callable[[float], None] | None = None) -> None:
        self.node, self.period, self.step, self.max_time = node, period, step, max_time
        self.on_origin = on_origin
        self.k = 0
        self.origin: float | None = origin  # None: fixed at the first tick (see above)
        self.offset = 0.0  # node time from the origin to step 0 of the current period
        self.timer = node.create_timer(period, self._tick)
        self._aligned = False
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
        self._align()

    def _align(self) -> None:
        """Run the periodic timer from the next due time on (class doc): a one-shot timer until then."""
        if self._aligned:
            return
        self._aligned = True
        now_ns = self.node.get_clock().now().nanoseconds
        self._catch_up(now_ns)  # steps already due go out now
        wait_ns = round(self.origin * NS) + self._due_ns(self.k + 1) - now_ns
        left = self.timer.time_until_next_call()
        if left is None or abs(left - wait_ns) <= PHASE_TOLERANCE * NS:  # cancelled (a lifecycle node resets
            return                                                        # it), or in phase already
        self.node.destroy_timer(self.timer)
        self.timer = self.node.create_timer(max(wait_ns, 0) / NS, self._first_due)

    def _first_due(self) -> None:
        self.node.destroy_timer(self.timer)
        self.timer = self.node.create_timer(self.period, self._tick)
        self._tick()

    def _tick(self) -> None:
        if self.origin is None:
            self._fix_origin()
        elif not self._aligned:  # an origin given at construction
            self._align()
        self._catch_up(self.node.get_clock().now().nanoseconds)

    def _catch_up(self, now_ns: int) -> None:
        """Every step due by ``now_ns``, one at a time, unless past ``max_time``."""
        origin_ns = round(self.origin * NS)
        max_ns = round(self.max_time * NS)
        while origin_ns + self._due_ns(self.k + 1) <= now_ns:
            if max_ns > 0 and self._due_ns(self.k + 1) > max_ns:
                return
            self.k += 1
            self.step(self.origin + self.offset + self.k * self.period)
