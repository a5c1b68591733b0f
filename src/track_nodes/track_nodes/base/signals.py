"""Stop signals: SIGTERM and SIGHUP end a process exactly as SIGINT (Ctrl-C) does.

``timeout``, systemd, ``docker stop`` and CI cancellation send SIGTERM; closing a terminal sends
SIGHUP. Their default action kills the process at once, so a recorder would leave an .mcap without
summary and no ``metadata.yaml``. ``stop_on(signal.SIGTERM, signal.SIGHUP)`` gives each of them a
handler that raises SIGINT in the process: whatever handles SIGINT then runs, unchanged (in a node
process, the stop below: the nodes are destroyed in order, the recorder closing its bag, and the
context is shut down last; elsewhere, Python's ``KeyboardInterrupt``).

A node process (``base/run.py``) initialises rclpy without its signal handlers
(``SignalHandlerOptions.NO``). rclpy's handler wakes a thread of its own that shuts every context down
at once, while the main thread goes on building or destroying the nodes: that race crashed the
process (SIGSEGV in a C thread) at about one stop in seven with four nodes stopping at once. Here the
main thread alone stops: the spin loop below ends, the nodes are destroyed, then the context.

Python runs a signal handler in the main thread between two bytecodes, so a main thread blocked
in C (an executor waiting with no timeout) would not see it; ``spin(executor)`` spins with a short
timeout (``POLL`` wall seconds) for that reason. A loop of one's own must wake up as often.

Teardown. Once a process is stopping, every further stop signal is a count (``HELD.count``), not an
exception: ``ros2 launch`` at Ctrl-C delivers the terminal's SIGINT and then its own, and SIGTERM 5 s
later; the second one used to land in the middle of destroying the nodes (Python's
``KeyboardInterrupt`` left teardown half done: exit 130, "process has died"). So the
Python handler of SIGINT that ``stop_on`` installs holds the stops (``hold_stops()``) before it raises
the ``KeyboardInterrupt`` of the first one: no instant is left between the first stop and the hold, not
even the few bytecodes before a ``finally``. Teardown is bounded by the DDS alarm
(``base/teardown.py``), so nothing is lost.

Spinning. A ``KeyboardInterrupt`` raised wherever the main thread happens to be can land inside an
object's ``__init__`` (an executor's ``Task`` for the next callback): the half-built object's
``__del__`` then prints a traceback, and a callback cut in the middle leaves its node's state half
updated. So while ``spin(executor)`` runs, the first stop only marks the process as stopping; the loop
ends after the callback in progress (a turn waits at most ``POLL``) and raises the
``KeyboardInterrupt`` there. Outside ``spin`` (building the nodes, a tool's own loop) it raises at once.

A signal that is ignored when ``stop_on`` is called (``nohup`` ignores SIGHUP) stays ignored. SIGINT
is handled even where it was ignored (a non-interactive shell's ``&`` does that): a process that
stops on SIGTERM stops on SIGINT too.
"""

from __future__ import annotations

import contextlib
import signal
from typing import Any

POLL = 0.25  # [wall s] the longest a stop signal waits for an idle executor
STOP_SIGNALS = (signal.SIGTERM, signal.SIGHUP)


def _as_sigint(signum: int, frame: Any) -> None:
    signal.raise_signal(signal.SIGINT)


def _first_stop(signum: int, frame: Any) -> None:
    """SIGINT: hold every later stop signal (module doc, Teardown), then stop as Ctrl-C does (inside
    ``spin``: at its next turn, module doc, Spinning)."""
    HELD.stopping = True
    hold_stops()
    if not HELD.spinning:
        raise KeyboardInterrupt


def stop_on(*signals: int) -> list[int]:
    """Make each of ``signals`` behave like SIGINT from now on, and SIGINT hold the later ones (module doc);
    returns those taken over.

    Call it from the main thread (elsewhere it does nothing), before ``rclpy.init``. Idempotent.
    """
    taken = []
    with contextlib.suppress(ValueError):  # not the main thread
        signal.signal(signal.SIGINT, _first_stop)  # also where it was ignored (a non-interactive shell's &)
        for sig in signals:
            if signal.getsignal(sig) is signal.SIG_IGN:
                continue  # asked to be ignored (nohup)
            signal.signal(sig, _as_sigint)
            taken.append(sig)
    return taken


class _Held:
    count = 0
    spinning = False  # inside spin(): a stop ends the loop at its next turn instead of raising where it lands
    # A stop signal arrived. Its KeyboardInterrupt, raised while rclpy is inside pybind11 (a take's message
    # conversion), comes out as a RuntimeError ('Unable to convert call argument'): that error is the stop.
    stopping = False


HELD = _Held()


def _count(signum: int, frame: Any) -> None:
    HELD.count += 1
    HELD.stopping = True


def hold_stops() -> None:
    """From now on a stop signal (SIGINT, SIGTERM, SIGHUP) is counted, not acted on (module doc, Teardown).

    Call it from the main thread when teardown begins (elsewhere it does nothing).
    """
    with contextlib.suppress(ValueError):
        for sig in (signal.SIGINT, *STOP_SIGNALS):
            if signal.getsignal(sig) is not signal.SIG_IGN:
                signal.signal(sig, _count)


def spin(executor) -> None:
    """``executor.spin()``, waking every ``POLL`` s so that a stop signal's Python handler runs; a stop
    signal raises ``KeyboardInterrupt`` here, between two turns (module doc, Spinning)."""
    HELD.spinning = True
    try:
        while executor.context.ok() and not HELD.stopping:
            executor.spin_once(timeout_sec=POLL)
    finally:
        HELD.spinning = False
    if HELD.stopping:
        raise KeyboardInterrupt
