"""How a run's ``/clock`` is paced: its epoch, its steps and the waits around them.

Shared by the launcher (``launcher``) and the ``clock`` node (``launch/clock.py``, the /clock of
``ros2 launch``), so a run of either starts at the same epoch and steps the same way:

- the epoch: whole seconds since 1970 (at least 1: ROS time 0 means "not set"), an ISO date in UTC,
  or ``now``: the whole minute of wall time when the clock starts (rcl phases a node-time timer
  from time 0, so an epoch that every period of a scenario divides keeps the timers on the
  simulators' step grids);
- the steps: min(R·``CLOCK_TICK``, ``MAX_CLOCK_STEP``) node seconds each, one per ``wall_step`` at
  most (never faster than R× the wall clock);
- with nodes in other processes, the clock is held at the epoch for ``SETTLE_PROCESSES`` after
  every node is up, so each node's first reading, which fixes its step origin (``FixedRateSteps``),
  is the epoch itself; after the last step, the run's work is done once no watched topic has
  delivered anything for ``QUIET`` seconds (at most ``DRAIN_MAX``), and ``GRACE`` more covers what
  is still in flight.
"""

from __future__ import annotations

import time
from datetime import UTC, datetime

CLOCK_TICK = 0.01  # wall seconds per /clock step at the nominal rate ...
MAX_CLOCK_STEP = 0.05  # ... but never more than this many node seconds per step (bounded bursts)
SETTLE = 1.0  # wall seconds for discovery to settle before the clock starts ...
SETTLE_PROCESSES = 3.0  # ... with one process per node (seen: a reader matched after 1 s lost step 0)
GRACE = 1.0  # wall seconds for messages in flight after the clock stops
QUIET = 2.0  # other processes: the graph is drained once no watched topic delivered for this long [wall s] ...
DRAIN_MAX = 120.0  # ... waiting at most this long after the clock stopped


class EpochError(ValueError):
    """An epoch that is not 'now', whole seconds in [1, 2^31 - 1] or an ISO date; the message is one line."""


def parse_epoch(text: str, flag: str = '--epoch') -> int | None:
    """Whole seconds since 1970 of ``text``, or None for 'now' (fixed when the clock starts: ``epoch_now``)."""
    if text == 'now':
        return None
    try:
        value = float(text)
    except ValueError:
        try:
            when = datetime.fromisoformat(text)
        except ValueError:
            raise EpochError(f"{flag} {text!r}: not 'now', seconds or an ISO date") from None
        value = (when if when.tzinfo else when.replace(tzinfo=UTC)).timestamp()
    if not (1 <= value <= 2**31 - 1 and value == int(value)):  # ROS time 0 means "not set"
        raise EpochError(f'{flag} {text!r}: must be whole seconds in [1, 2^31 - 1] (ROS time 0 is unset)')
    return int(value)


def epoch_now() -> int:
    """The epoch 'now' stands for: the whole minute of wall time (module docstring)."""
    return int(time.time()) // 60 * 60


def epoch_line(epoch: int, flag: str = '--epoch') -> str:
    return f'/clock from {datetime.fromtimestamp(epoch, UTC):%Y-%m-%d %H:%M:%S} UTC ({flag} {epoch})'


def clock_step(rate: float) -> tuple[float, float]:
    """(node seconds per /clock step, wall seconds per step) at ``rate`` × real time (> 0)."""
    step = min(rate * CLOCK_TICK, MAX_CLOCK_STEP)
    return step, step / rate


def node_time(k: int, step: float, duration: float | None) -> float:
    """Node time of step ``k`` since the epoch [s], never past ``duration``."""
    return k * step if duration is None else min(k * step, duration)
