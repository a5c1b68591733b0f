"""The lock-step loop of a one-process run, and the watchdog that keeps it from waiting forever.

Lock-step means: after each /clock step the launcher runs every callback that became ready, in
its own thread and in order, until the graph is idle; only then does the clock advance. "Idle"
is only true if no callback can be running anywhere else, so in lock-step no callback is ever
handed to the executor's thread pool, not even while the launcher waits for the wall time of the
next step (``run_ready`` with a deadline). A callback handed to the pool finishes on its own
time: its completion wakes nobody who decides "idle", its messages can land after the clock has
moved on, and while it runs it holds its node's mutually exclusive callback group, which hides
that node's other ready entities (its /clock subscription among them) from every wait set. With
one thread that cannot happen: what is ready is in the wait set, and what ran is finished.

The watchdog (a thread) stops a run whose clock has not advanced for ``Watchdog.deadline`` wall
seconds with one line that names what the step waits for: the callback that has not returned
(node and topic), or the callbacks that keep the graph from becoming idle.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
import time
from collections import Counter, deque
from collections.abc import Callable

from rclpy.context import Context
from rclpy.executors import Executor, ExternalShutdownException, ShutdownException, TimeoutException

from track_nodes.launch.tuning import IDLE_POLL, STALL_MIN, STALL_PER_NODE, STALL_STEPS, STOP_GRACE


class Watchdog:
    """Watches the clock steps of a run; ``start`` it, call ``stepped`` at every step, ``stop`` it."""

    def __init__(self, n_nodes: int, fixed: float | None = None) -> None:
        self.n_nodes = n_nodes
        self.fixed = fixed
        self.steps: deque[float] = deque(maxlen=200)  # wall durations of the recent steps
        self.last_step = time.monotonic()
        self.node_time = 0.0
        self.running: tuple[str, float] | None = None  # the callback running now, since (monotonic)
        self.ran: Counter[str] = Counter()  # callbacks run in this step
        self.stalled: str | None = None
        self.watching = True  # False once the run's clock has stopped
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._watch, name='launch-watchdog', daemon=True)
        self._main = threading.main_thread().ident

    def deadline(self) -> float:
        """Wall seconds a step may take: generous, from the node count and the recent step times."""
        if self.fixed is not None:
            return self.fixed
        return max(STALL_MIN, STALL_PER_NODE * self.n_nodes, STALL_STEPS * max(self.steps, default=0.0))

    def stepped(self, node_time: float) -> None:
        now = time.monotonic()
        self.steps.append(now - self.last_step)
        self.last_step, self.node_time = now, node_time
        self.ran.clear()

    def calling(self, what: str | None) -> None:
        """The launcher's thread is about to run the callback ``what`` (None: it returned)."""
        if what is None:
            self.running = None
        else:
            self.running = (what, time.monotonic())
            self.ran[what] += 1

    def describe(self, waited: float) -> str:
        head = (f'/clock has not advanced for {waited:.0f} s (deadline {self.deadline():.0f} s) '
                f'at node time {self.node_time:.2f} s')
        running = self.running
        if running is not None:
            return f'{head}: waiting for {running[0]}, which has not returned for {time.monotonic() - running[1]:.0f} s'
        if self.ran:
            busiest = ', '.join(f'{what} ({n}x)' for what, n in self.ran.most_common(3))
            return f'{head}: the graph never became idle; callbacks run in this step: {busiest}'
        return f'{head}: no callback ran in this step'

    def start(self) -> Watchdog:
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()

    def _watch(self) -> None:
        while not self._stop.wait(0.2):
            waited = time.monotonic() - self.last_step
            if self.watching and waited > self.deadline():
                self.stalled = self.describe(waited)
                print(f'track_nodes.launch: stopped: {self.stalled}', file=sys.stderr, flush=True)
                signal.pthread_kill(self._main, signal.SIGINT)  # the usual clean stop (bag closed)
                if not self._stop.wait(STOP_GRACE):
                    print(f'track_nodes.launch: the run did not stop within {STOP_GRACE:.0f} s of the stall; '
                          'exiting', file=sys.stderr, flush=True)
                    os._exit(1)
                return


def describe_entity(entity, node) -> str:
    """'the callback of NODE on TOPIC' (or its timer, service, ...), for the watchdog's line."""
    name = node.get_name() if node is not None else '?'
    for attr, kind in (('topic_name', 'subscription to'), ('srv_name', 'service'), ('timer_period_ns', None)):
        value = getattr(entity, attr, None)
        if value is None:
            continue
        if kind is None:
            return f'the timer of {name} (every {value * 1e-9:g} s)'
        return f'the callback of {name} ({kind} {value})'
    return f'the callback of {name} ({type(entity).__name__})'


def run_ready(executor: Executor, context: Context, deadline: float | None, interrupted: Callable[[], bool],
              watchdog: Watchdog | None = None) -> None:
    """Run ready callbacks inline, in order: until none is ready twice in a row (``deadline`` None),
    else until ``deadline`` (monotonic s)."""
    idle = 0
    while context.ok():
        if interrupted():
            raise KeyboardInterrupt  # a stop signal, taken between two callbacks (launcher._on_stop_signal)
        if deadline is None:
            if idle >= 2:
                return
            timeout = IDLE_POLL
        else:
            timeout = deadline - time.monotonic()
            if timeout <= 0:
                return
        try:
            handler, entity, node = executor.wait_for_ready_callbacks(timeout_sec=min(timeout, 0.005))
        except TimeoutException:
            idle += 1
            continue
        except (ShutdownException, ExternalShutdownException):
            return
        idle = 0
        if watchdog is not None:
            watchdog.calling(describe_entity(entity, node))
        handler()
        if watchdog is not None:
            watchdog.calling(None)
        if handler.exception() is not None:
            if interrupted():  # Ctrl-C inside a callback (e.g. during a take): a clean stop
                raise KeyboardInterrupt from handler.exception()
            raise handler.exception()
