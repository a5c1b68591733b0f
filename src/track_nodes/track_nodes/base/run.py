"""``run_node`` / ``run_nodes``: the ``main`` of every executable (``TrackNode.main``, ``node_group``).

``rclpy.init`` → build the nodes → spin until SIGINT, SIGTERM or SIGHUP (alike: ``base.signals``) or
shutdown → destroy (which closes files) → exit code. A bad command line, params file or parameter
(``ValueError``, ``OSError`` at start) prints one line on stderr and exits 2, without a traceback.
Once teardown begins, further stop signals are held (``base.signals.hold_stops``), so a second
Ctrl-C cannot cut it short.
"""

from __future__ import annotations

import contextlib
import faulthandler
import signal
import sys
from collections.abc import Callable, Sequence
from typing import Any

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions

from track_nodes.base import ready
from track_nodes.base.cli import params_file_problem
from track_nodes.base.names import remember_args
from track_nodes.base.signals import HELD, STOP_SIGNALS, hold_stops, spin, stop_on
from track_nodes.base.teardown import TEARDOWN, dds_alarm

EXIT_BAD_INPUT = 2


def run_node(factory: Callable[..., Node], argv: Sequence[str] | None = None, **kwargs: Any) -> int:
    """Run one node until shutdown; return the process exit code (0, or 2 for bad input)."""
    name = getattr(factory, 'DEFAULT_NAME', getattr(factory, '__name__', 'node'))
    return run_nodes([(name, lambda: factory(**kwargs))], argv, program=name)


def run_nodes(makers: Sequence[tuple[str, Callable[[], Node]]], argv: Sequence[str] | None = None,
              program: str = 'node') -> int:
    """Build every ``(name, maker)`` in one process and spin them on one executor until shutdown.

    Exit code 0, or 2 for bad input: a bad command line, params file or parameter of any node is one
    line on stderr (``<name>: <problem>``) and nothing runs.
    """
    args = list(sys.argv if argv is None else argv)
    # A process that does not stop gets SIGUSR1 from the launcher before the kill (launch/processes.py):
    # every thread's Python stack goes to stderr (a C-level handler: it fires with the main thread in C too).
    # A crash in C (SIGSEGV, SIGABRT, ...) prints every thread's Python stack too, before the process dies.
    with contextlib.suppress(AttributeError, ValueError, RuntimeError):
        faulthandler.register(signal.SIGUSR1, all_threads=True)
        faulthandler.enable(all_threads=True)
    stop_on(*STOP_SIGNALS)  # SIGTERM and SIGHUP stop the nodes as SIGINT does (base/signals.py)
    problem = params_file_problem(args)
    if problem is None:
        try:
            # No rclpy signal handlers: its signal thread shut the context down while this thread was
            # building or destroying the nodes, a race that crashed about one stop in seven under load
            # (SIGSEGV); the stop is ours alone, and teardown shuts the context down itself (base/signals.py).
            rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
            remember_args(rclpy.get_default_context(), args)  # its params files, for base/names.py
        except _rclpy.UnknownROSArgsError as exc:
            problem = f'unknown ROS arguments {exc}'
        except _rclpy.RCLError as exc:  # other arguments rcl refuses: the first line of its message
            problem = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
    if problem is not None:
        print(f'{program}: {problem}', file=sys.stderr)
        return EXIT_BAD_INPUT
    nodes: list[Node] = []
    TEARDOWN.alarm = True  # a node process: a DDS deletion that hangs ends it (base/teardown.py)
    ready.HOLD.held = True  # the nodes announce themselves once no older twin was heard (base/ready.py)
    twins = None
    try:
        # Made before any node announces itself: a stop signal that lands inside an executor's __init__
        # leaves a half-built object whose __del__ prints a traceback, so not while others may signal us.
        executor = rclpy.get_global_executor() if len(makers) == 1 else SingleThreadedExecutor()
        for name, make in makers:
            try:
                nodes.append(make())
            except (ValueError, OSError) as exc:
                if not rclpy.ok():
                    raise  # Ctrl-C while starting, handled below
                print(f'{name}: {exc}', file=sys.stderr)
                return EXIT_BAD_INPUT
        twins = ready.settle(nodes, program, EXIT_BAD_INPUT)  # no older twin heard: announced (base/ready.py)
        for node in [*nodes, twins.node]:
            executor.add_node(node)
        with contextlib.suppress(KeyboardInterrupt, ExternalShutdownException):
            spin(executor)  # wakes up for stop signals (base/signals.py)
    except (Exception, KeyboardInterrupt) as exc:  # a clean stop: Ctrl-C (raised before rclpy's signal thread
        stop = isinstance(exc, KeyboardInterrupt) or HELD.stopping  # shut the context, or turned into another
        if rclpy.ok() and not stop:                     # error inside C code), or a context shut down under the
            raise                                       # nodes being built or a callback; else a bug
    finally:
        hold_stops()  # a second Ctrl-C (ros2 launch sends one) must not cut teardown short (base/signals.py)
        _teardown(nodes, twins.node if twins else None)
    return max((getattr(node, 'exit_code', 0) for node in nodes), default=0)


def _teardown(nodes: list[Node], twins: Node | None) -> None:
    """Destroy the nodes, then the twins' node and the context, each DDS deletion under the alarm."""
    for node in nodes:
        node.destroy_node()  # a TrackNode closes its files, then deletes its DDS entities under the alarm
    if twins is not None:
        with dds_alarm():  # the last node of the context takes the DDS participant with it (rmw_fastrtps)
            twins.destroy_node()
    with dds_alarm():
        rclpy.try_shutdown()
    TEARDOWN.done = True
