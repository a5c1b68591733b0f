"""What every node shares: declared, range-checked parameters and a clean ``main``.

- ``Param`` + ``declare_params``: every parameter gets a description and, for numbers, a
  range in its ParameterDescriptor (so ``ros2 param describe`` shows it). A value outside
  the range, of the wrong type or not among ``choices`` raises ``ParameterError`` with one
  line naming the parameter, the value and what is allowed.
- ``run_node``: ``rclpy.init`` → build the node → spin until SIGINT/SIGTERM or
  shutdown → destroy (which closes files) → exit code. A bad parameter or bad input at
  start prints that one line on stderr and exits 2, without a traceback.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from types import SimpleNamespace
from typing import Any

import rclpy
from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
from rclpy.exceptions import ParameterException
from rclpy.executors import ExternalShutdownException, MultiThreadedExecutor
from rclpy.node import Node

EXIT_BAD_INPUT = 2


class ParameterError(ValueError):
    """A node parameter has an invalid value; the message is one line."""


@dataclass(frozen=True)
class Param:
    """Declaration of one node parameter. ``lo``/``hi`` are inclusive bounds for numbers."""

    name: str
    default: Any
    description: str
    lo: float | None = None
    hi: float | None = None
    choices: tuple[str, ...] | None = None

    def allowed(self) -> str:
        if self.choices is not None:
            return 'one of ' + ', '.join(self.choices)
        lo = '-inf' if self.lo is None else f'{self.lo:g}'
        hi = 'inf' if self.hi is None else f'{self.hi:g}'
        return f'[{lo}, {hi}]'

    def descriptor(self) -> ParameterDescriptor:
        d = ParameterDescriptor(name=self.name, description=f'{self.description} (allowed: {self.allowed()})')
        if isinstance(self.default, bool) or (self.lo is None and self.hi is None):
            return d
        lo = -sys.float_info.max if self.lo is None else self.lo
        hi = sys.float_info.max if self.hi is None else self.hi
        if isinstance(self.default, int):
            d.integer_range = [IntegerRange(from_value=int(max(lo, -(2**62))), to_value=int(min(hi, 2**62)), step=0)]
        elif isinstance(self.default, float):
            d.floating_point_range = [FloatingPointRange(from_value=float(lo), to_value=float(hi), step=0.0)]
        return d

    def check(self, value: Any) -> None:
        if self.choices is not None and value not in self.choices:
            raise ParameterError(f'parameter {self.name}={value!r} is invalid: allowed {self.allowed()}')
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            bad_lo = self.lo is not None and not value >= self.lo
            bad_hi = self.hi is not None and not value <= self.hi
            if bad_lo or bad_hi or math.isnan(value):
                raise ParameterError(f'parameter {self.name}={value!r} is out of range: allowed {self.allowed()}')


def declare_params(node: Node, specs: Iterable[Param]) -> SimpleNamespace:
    """Declare ``specs`` on ``node`` and return their checked values as attributes."""
    values = {}
    for spec in specs:
        try:
            param = node.declare_parameter(spec.name, spec.default, spec.descriptor())
        except ParameterException as exc:
            # rclpy's own range/type checks: keep only the first line of its message.
            first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            raise ParameterError(f'parameter {spec.name}: {first} (allowed: {spec.allowed()})') from None
        value = param.value
        spec.check(value)
        values[spec.name] = value
    return SimpleNamespace(**values)


def run_node(factory: Callable[..., Node], argv: Sequence[str] | None = None, *, multithreaded: bool = False,
             **kwargs: Any) -> int:
    """Run one node until shutdown; return the process exit code (0, or 2 for bad input)."""
    args = list(sys.argv if argv is None else argv)
    rclpy.init(args=args)
    try:
        node = factory(**kwargs)
    except (ValueError, OSError) as exc:
        name = getattr(factory, 'DEFAULT_NAME', getattr(factory, '__name__', 'node'))
        print(f'{name}: {exc}', file=sys.stderr)
        rclpy.try_shutdown()
        return EXIT_BAD_INPUT
    executor = MultiThreadedExecutor() if multithreaded else None
    try:
        rclpy.spin(node, executor=executor)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return getattr(node, 'exit_code', 0)


class FixedRateSteps:
    """Call ``step(t)`` once per ``period`` of node time, at t = origin + k·period exactly.

    Stamps come from the step counter, not from when the timer happened to fire, and a late
    timer catches up one step at a time, so a seeded simulator publishes the same payloads
    whatever the executor timing. Under ``use_sim_time`` the origin is 0 (the launcher's
    clock starts there); on wall time it is the whole second at the first tick.
    ``max_time`` > 0 stops stepping after that much node time since the origin.
    """

    def __init__(self, node: Node, period: float, step: Callable[[float], None], max_time: float = 0.0) -> None:
        self.node, self.period, self.step, self.max_time = node, period, step, max_time
        self.k = 0
        self.origin: float | None = None
        self.timer = node.create_timer(period, self._tick)

    def _tick(self) -> None:
        now = self.node.get_clock().now().nanoseconds * 1e-9
        if self.origin is None:
            self.origin = 0.0 if self.node.get_parameter('use_sim_time').value else float(math.floor(now))
        while self.origin + (self.k + 1) * self.period <= now + 1e-9:
            if self.max_time > 0 and (self.k + 1) * self.period > self.max_time + 1e-9:
                return
            self.k += 1
            self.step(self.origin + self.k * self.period)
