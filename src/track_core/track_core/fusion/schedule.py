"""Scoring instants taken from the reports' stamps (the fusion node's ``schedule:=stamps``).

The instants are t_k = k/``rate`` of the *data*, the first one at or after the first report's
stamp. t_k is due once a report stamped ≥ t_k + 1/``rate`` has arrived; the reports released for
it are the queued ones stamped ≤ t_k, in (stamp, key) order rather than arrival order, so that a
table filled with them (pair names, marker ids) does not depend on which source's message came
first. The output then depends only on the reports' stamps and contents, not on when they arrive,
as long as every report stamped ≤ t_k arrives before any report stamped ≥ t_k + 1/``rate``. A jump
of more than ``max_skip`` instants in the data's time skips the empty instants in between.
"""

from __future__ import annotations

import math
from typing import Any

_EPS = 1e-9  # stamps are nanosecond-rounded: compare with a tolerance below one nanosecond


class StampSchedule:
    """Queue of reports keyed by stamp; ``push`` returns the instants that became due."""

    def __init__(self, rate: float, max_skip: int = 10_000) -> None:
        if not rate > 0:
            raise ValueError(f'rate must be > 0 Hz, got {rate}')
        self.rate, self.max_skip = float(rate), max_skip
        self.next_k: int | None = None  # index of the next instant k/rate to score
        self.pending: list[tuple[float, str, Any]] = []  # (stamp, key, item) not yet released

    def push(self, t: float, key: str, item: Any) -> list[tuple[float, list[Any]]]:
        """Queue ``item`` stamped ``t``; return [(t_k, items released for t_k)] of the instants now due.

        The caller applies each instant's items, then scores t_k, in the returned order. ``item`` is
        released at a later push (the instants due now all lie before ``t``).
        """
        due = self._due(t)
        self.pending.append((t, key, item))
        return due

    def _due(self, t_new: float) -> list[tuple[float, list[Any]]]:
        rate = self.rate
        if self.next_k is None:
            self.next_k = math.ceil(t_new * rate - _EPS)
        if (t_new * rate - self.next_k) > self.max_skip:  # a jump in the data's time: skip the empty instants
            self.next_k = math.ceil(t_new * rate - _EPS) - 1
        out: list[tuple[float, list[Any]]] = []
        if (self.next_k + 1) / rate > t_new + _EPS:
            return out
        pending = sorted(self.pending, key=lambda r: (r[0], r[1]))  # stable: ties keep arrival order
        while (self.next_k + 1) / rate <= t_new + _EPS:
            t_k = self.next_k / rate
            n = next((i for i, r in enumerate(pending) if r[0] > t_k + _EPS), len(pending))
            out.append((t_k, [r[2] for r in pending[:n]]))
            pending = pending[n:]
            self.next_k += 1
        self.pending = pending
        return out
