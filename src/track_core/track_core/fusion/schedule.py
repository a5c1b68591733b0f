"""Scoring instants taken from the reports' stamps (the fusion node's ``schedule:=stamps``).

The instants are t_k = k/``rate`` of the *data*, the first one at or after the first report's
stamp. t_k is due once a report stamped ≥ t_k + 1/``rate`` has arrived; the reports released for
it are the queued ones stamped ≤ t_k, in (stamp, key) order rather than arrival order, so that a
table filled with them (pair names, marker ids) does not depend on which source's message came
first. The output then depends only on the reports' stamps and contents, not on when they arrive,
as long as every report stamped ≤ t_k arrives before any report stamped ≥ t_k + 1/``rate``.

That holds in one process stepped in lock-step, not across processes: one source's report for t_k
can arrive after another's for t_k + 1/``rate`` (a network leader that is a step behind the radar).
So with ``streams`` (the input topics, each delivering its reports in stamp order) an instant is
due only once every stream has delivered a report stamped ≥ t_k + 1/``rate`` (its *watermark*), or
once the newest stamp of any stream is ``max_wait`` beyond that (a silent or dead stream is waited
for that long in data time, then scored without). The first instant is the first at or after the
earliest stamp queued when it becomes due. Without ``streams`` the newest stamp is the watermark
and the first instant follows the first report, as above. A jump of more than ``max_skip``
instants in the data's time skips the empty instants in between.
"""

from __future__ import annotations

import math
from typing import Any

_EPS = 1e-9  # stamps are nanosecond-rounded: compare with a tolerance below one nanosecond


class StampSchedule:
    """Queue of reports keyed by stamp; ``push`` returns the instants that became due."""

    def __init__(self, rate: float, max_skip: int = 10_000, streams: tuple[str, ...] = (),
                 max_wait: float = math.inf) -> None:
        if not rate > 0:
            raise ValueError(f'rate must be > 0 Hz, got {rate}')
        if not max_wait >= 0:
            raise ValueError(f'max_wait must be >= 0 s, got {max_wait}')
        self.rate, self.max_skip = float(rate), max_skip
        self.streams, self.max_wait = tuple(streams), float(max_wait)
        self.next_k: int | None = None  # index of the next instant k/rate to score
        self.pending: list[tuple[float, str, Any]] = []  # (stamp, key, item) not yet released
        self.latest: dict[str, float] = dict.fromkeys(self.streams, -math.inf)  # watermark of each stream
        self.newest = -math.inf  # the newest stamp pushed

    def push(self, t: float, key: str, item: Any, stream: str | None = None) -> list[tuple[float, list[Any]]]:
        """Queue ``item`` stamped ``t`` (from ``stream``); return [(t_k, items released for t_k)] of the
        instants now due, which the caller applies and scores in the returned order."""
        if self.next_k is None and not self.latest:  # no streams: the first instant follows the first report
            self.next_k = math.ceil(t * self.rate - _EPS)
        self.pending.append((t, key, item))
        return self.heard(stream, t)

    def heard(self, stream: str | None, t: float) -> list[tuple[float, list[Any]]]:
        """``stream`` delivered stamp ``t`` (with or without an item): → the instants now due."""
        self.newest = max(self.newest, t)
        if stream is not None:
            self.latest[stream] = max(self.latest.get(stream, -math.inf), t)
        return self._due(self._watermark())

    def _watermark(self) -> float:
        """Data time up to which every stream has delivered (module docstring)."""
        if not self.latest:
            return self.newest
        return max(min(self.latest.values()), self.newest - self.max_wait)

    def _due(self, horizon: float) -> list[tuple[float, list[Any]]]:
        rate = self.rate
        out: list[tuple[float, list[Any]]] = []
        if not math.isfinite(horizon) or (not self.pending and self.next_k is None):
            return out
        if self.next_k is None:
            first = min(r[0] for r in self.pending)
            if horizon + _EPS < (math.ceil(first * rate - _EPS) + 1) / rate:
                return out
            self.next_k = math.ceil(first * rate - _EPS)
        if (horizon * rate - self.next_k) > self.max_skip:  # a jump in the data's time: skip the empty instants
            self.next_k = math.ceil(horizon * rate - _EPS) - 1
        if (self.next_k + 1) / rate > horizon + _EPS:
            return out
        pending = sorted(self.pending, key=lambda r: (r[0], r[1]))  # stable: ties keep arrival order
        while (self.next_k + 1) / rate <= horizon + _EPS:
            t_k = self.next_k / rate
            n = next((i for i, r in enumerate(pending) if r[0] > t_k + _EPS), len(pending))
            out.append((t_k, [r[2] for r in pending[:n]]))
            pending = pending[n:]
            self.next_k += 1
        self.pending = pending
        return out
