"""How a run's ``/clock`` is paced: its steps and the waits around them.

Shared by the launcher (``launcher``) and the ``clock`` node (``launch/clock.py``, the /clock of
``ros2 launch``), so a run of either starts at the same epoch (``track_nodes.base.epoch``) and steps
the same way (the constants are ``tuning``'s):

- ``now`` as an epoch: the whole minute of wall time when the clock starts (rcl phases a node-time
  timer from time 0, so an epoch that every period of a scenario divides keeps the timers on the
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

from track_nodes.launch.tuning import CLOCK_TICK, HOLD_MAX, LAG_PERIODS, MAX_CLOCK_STEP, SAME_GAP_NS


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
    every step). A topic that once showed a gap of another length, or kept the clock waiting
    ``HOLD_MAX`` wall seconds (it stopped), is driven by events (an IDSQ handoff goes where the
    leader goes) and holds it no more in this run: otherwise every sensor that received a few
    handoffs at one period and then none stalled the clock ``HOLD_MAX`` again, more often the
    longer the run.
    """

    def __init__(self) -> None:
        self.last: dict[str, int] = {}  # topic -> latest stamp [ns]
        self.gaps: dict[str, tuple[int, ...]] = {}  # topic -> its last two stamp gaps [ns]
        self.waiting: tuple[str, float] | None = None  # the topic holding the clock, since (monotonic)
        self.events: set[str] = set()  # topics that showed an irregular gap or a stop: they hold nothing

    def seen(self, topic: str, t_ns: int) -> None:
        prev = self.last.get(topic)
        if prev is not None and t_ns <= prev:
            return
        if prev is not None:
            self.gaps[topic] = gaps = (*self.gaps.get(topic, ())[-1:], t_ns - prev)
            if len(gaps) == 2 and abs(gaps[0] - gaps[1]) > SAME_GAP_NS:
                self.events.add(topic)
        self.last[topic] = t_ns

    def period(self, topic: str) -> int | None:
        gaps = self.gaps.get(topic, ())
        if topic in self.events or len(gaps) < 2 or abs(gaps[0] - gaps[1]) > SAME_GAP_NS:
            return None
        return gaps[-1]

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
            self.events.add(topic)  # it keeps us waiting: stopped, or not periodic after all
            self.waiting = None
        return None
