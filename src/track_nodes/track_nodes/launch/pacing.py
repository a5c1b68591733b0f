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


# --- holding the clock for other processes ---------------------------------------------------------
HOLD_MAX = 5.0  # [wall s] the longest the clock waits for one topic; then that topic no longer holds it
LAG_PERIODS = 3  # the clock waits for a periodic topic whose latest stamp L is this many periods old (Cadence)
SAME_GAP_NS = 1_000  # two stamp gaps within this are the same period


def header_stamp_ns(cdr: bytes) -> int | None:
    """The ``header.stamp`` [ns] of a serialized message whose first field is a std_msgs/Header, or None."""
    if len(cdr) < 12:
        return None
    order = 'little' if cdr[1] & 1 else 'big'  # CDR encapsulation: 0x0001 little endian, 0x0000 big
    sec = int.from_bytes(cdr[4:8], order, signed=True)
    nanosec = int.from_bytes(cdr[8:12], order)
    return sec * 1_000_000_000 + nanosec if nanosec < 1_000_000_000 else None


class Cadence:
    """The stamps of the run's periodic topics, to keep a multi-process run's /clock from outrunning them.

    In one process the launcher runs every callback of a step before the next (lock-step). Nodes in
    other processes cannot be observed, and on a busy machine a slow one (an IDSQ field of 40 sensors
    in one process) can fall a whole step behind the others: a node that merges topics by stamp (the
    fusion node's ``schedule:=stamps``) then sees a later stamp of one topic before an earlier one of
    another, and scores differently (the stamp schedule now waits for every input's watermark, so it no
    longer depends on this; a network far behind still would, after ``stamps_max_wait``). A topic is
    *periodic* once its last two stamp gaps are equal (period P); the clock must not reach
    L + ``LAG_PERIODS``·P while its latest stamp is L, i.e. its message of L + P (due at node time
    L + P) must have arrived before the clock passes two more periods. Two, not one: a topic computed
    from other processes' messages of the next period trails by a period of its own. The fusion node's
    instant t is due once every input has delivered t + P, the network's estimate of t + P leaves after
    node time t + P, so the fusion's output of t leaves after t + P too; with one period the clock
    would wait at t + 2P for an output that needs the network's t + 2P (a stall of ``HOLD_MAX`` at
    every step). A topic that keeps the clock waiting ``HOLD_MAX`` wall seconds (it stopped, or was
    never periodic) holds it no more until it shows a period again.
    """

    def __init__(self) -> None:
        self.last: dict[str, int] = {}  # topic -> latest stamp [ns]
        self.gaps: dict[str, tuple[int, ...]] = {}  # topic -> its last two stamp gaps [ns]
        self.waiting: tuple[str, float] | None = None  # the topic holding the clock, since (monotonic)

    def seen(self, topic: str, t_ns: int) -> None:
        prev = self.last.get(topic)
        if prev is not None and t_ns <= prev:
            return
        if prev is not None:
            self.gaps[topic] = (*self.gaps.get(topic, ())[-1:], t_ns - prev)
        self.last[topic] = t_ns

    def period(self, topic: str) -> int | None:
        gaps = self.gaps.get(topic, ())
        return gaps[-1] if len(gaps) == 2 and abs(gaps[0] - gaps[1]) <= SAME_GAP_NS else None

    def holding(self, next_ns: int, now: float) -> str | None:
        """The topic that must deliver before /clock may reach ``next_ns`` (None: go on)."""
        for topic in sorted(self.gaps):
            p = self.period(topic)
            if p is None or next_ns < self.last[topic] + LAG_PERIODS * p:
                continue
            if self.waiting is None or self.waiting[0] != topic:
                self.waiting = (topic, now)
            if now - self.waiting[1] < HOLD_MAX:
                return topic
            self.gaps.pop(topic)  # it keeps us waiting: stopped, or not periodic after all
            self.waiting = None
        return None
