"""Which time the recorder stamps messages with: the ``clock`` parameter (``--clock``).

- ``auto`` (the default): sim time if ``/clock`` is published, else wall time. The recorder
  subscribes to ``/clock`` itself and holds the messages it takes (with their receive times)
  until it knows: the first ``/clock`` message decides sim time, ``clock_wait`` wall seconds after
  the first message without one decide wall time. A ``/clock`` publisher that sends nothing (the
  launcher's in a wall-time run) does not count. Under sim time a message is stamped with the
  latest ``/clock`` value received; the held ones with the first. A ``/clock`` that starts only
  after wall time was chosen is named in one warning; the bag stays on wall time (a bag mixing
  the two would go back in time).
- ``sim``: the node's clock under ``use_sim_time`` (set by ``clock:=sim``; ``use_sim_time:=true``
  alone means the same). Messages taken before the first /clock are written at its first
  reading (``bag.batching.BeforeClock``).
- ``wall``: the middleware's receive time of each message (system clock).

The recorder calls ``write_batch`` and ``decide`` under its lock. Everything goes to the bag as
batches (``write_many(conn, stamps, raws)``, ``bag.durable``): one stamp list per batch, no
per-message call.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

from track_nodes.bag.batching import BeforeClock
from track_nodes.base.params import ParameterError

MODES = ('auto', 'sim', 'wall')


def received(infos: Sequence[dict]) -> list[int]:
    """The middleware's receive times [ns, system clock]; now for a message without one."""
    now = time.time_ns()
    return [info.get('received_timestamp') or now for info in infos]


class ClockChoice:
    """The recorder's stamping: ``mode`` is 'node' (use_sim_time), 'sim' (/clock as received), 'wall' or 'auto'."""

    def __init__(self, mode: str, use_sim_time: bool, wait: float) -> None:
        if mode not in MODES:
            raise ParameterError(f'parameter clock={mode!r}: expected one of {", ".join(MODES)}')
        if mode == 'wall' and use_sim_time:
            raise ParameterError('parameter clock=wall contradicts use_sim_time=true: choose one')
        self.mode = 'node' if use_sim_time or mode == 'sim' else mode
        self.wait = wait
        self.latest = 0  # the last /clock value received [ns] (auto and sim)
        self.first = None  # steady time of the first message taken while auto is undecided
        self.held: list[tuple[Any, Sequence[bytes], list[int]]] = []  # batches (conn, CDR, receive times)
        self.before = BeforeClock()
        self.warned = False

    def on_clock(self, ns: int) -> None:
        self.latest = max(self.latest, ns)

    def write_batch(self, write_many, conn, raws: Sequence[bytes], infos: Sequence[dict], node_clock) -> None:
        """Write (or hold) one batch of CDR messages taken from one subscription, with their message infos."""
        mode = self.mode
        if mode == 'auto':
            self.first = self.first if self.first is not None else time.monotonic()
            self.held.append((conn, raws, received(infos)))
            return
        if mode == 'wall':
            write_many(conn, received(infos), raws)
            return
        now = node_clock.now().nanoseconds if mode == 'node' else self.latest
        if now == 0:  # before the first /clock: written at its first reading
            self.before.hold(conn, raws)
            return
        self.before.release(write_many, now)
        write_many(conn, [now] * len(raws), raws)

    def decide(self, write_many, final: bool = False) -> str | None:
        """While auto is undecided: choose when due (or ``final``, at close) and write what was held.

        Returns the line to log when a choice was made (or when /clock started too late)."""
        if self.mode != 'auto':
            if self.mode == 'wall' and self.latest and not self.warned and self.first is not None:
                self.warned = True
                return ('/clock is published now, but this bag is stamped with wall time (no /clock within '
                        f'{self.wait:g} s of the first message); to follow a sim-time run, start the run first '
                        'or record with --clock sim')
            return None
        if self.latest:
            self.mode = 'sim'
            for conn, raws, _ in self.held:
                write_many(conn, [self.latest] * len(raws), raws)
            line = 'stamping with /clock (sim time): it is published'
        elif final or (self.first is not None and time.monotonic() - self.first >= self.wait):
            self.mode = 'wall'
            for conn, raws, stamps in self.held:
                write_many(conn, stamps, raws)
            line = f'stamping with wall time: no /clock within {self.wait:g} s of the first message'
        else:
            return None
        self.held = []
        return line

    def close(self, write_many) -> None:
        self.decide(write_many, final=True)
        self.before.release(write_many, 0)  # the clock never started: log time 0
