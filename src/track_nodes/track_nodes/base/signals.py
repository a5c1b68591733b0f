"""Stop signals: SIGTERM and SIGHUP end a process exactly as SIGINT (Ctrl-C) does.

``stop_on(signal.SIGTERM, signal.SIGHUP)`` gives each of them a handler that raises SIGINT in the
process: whatever handles SIGINT then runs, unchanged (in a node process the stop below; elsewhere
Python's ``KeyboardInterrupt``). Without it ``timeout``, systemd, ``docker stop`` or a closed
terminal would kill a recorder before it writes its summary and ``metadata.yaml``.

- A node process (``base/run.py``) initialises rclpy without its signal handlers
  (``SignalHandlerOptions.NO``): the main thread alone stops (spin ends, nodes destroyed, then the
  context).
- ``spin(executor)`` spins with a ``POLL`` wall-second timeout so the main thread sees a signal; a
  loop of one's own must wake as often. While it runs, the first stop only marks the process as
  stopping; the loop ends after the callback in progress and raises ``KeyboardInterrupt`` there.
  Outside ``spin`` it raises at once.
- Once stopping, every further stop signal is counted (``HELD.count``, ``hold_stops()``), not
  raised, so teardown is never cut short (it is bounded by ``base/teardown.py``).
- A signal ignored when ``stop_on`` is called (``nohup``'s SIGHUP) stays ignored; SIGINT is handled
  even where it was ignored. Why each rule: docs/MODULES.md, "Stop signals".
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
