"""``StreamMerger``: the two SLAM input streams (vehicle inputs, laser scans) merged into stamp order.

The filter must see inputs and scans in stamp order, but a node receives them on two
subscriptions and, with a backlog, the (8× rarer) scans run ahead of the inputs before them. So
events are buffered and released in stamp order (at equal stamps the scan first, as
``victoria.events``) up to the *watermark*: the older of the last input and the last scan stamp.
Each stream is monotonic (``offer`` refuses a stamp going backwards or older than what was
released), so nothing older than the watermark can still come.

- Pause: a stream silent for ``pause_wall`` s while the other delivered at least two events is left
  out of the watermark. "Silent" means nothing queued and no message at all: the node offers
  everything waiting first, and says when each stream last delivered any message (``heard``),
  refused ones included. With neither stream bounding it, ``watermark`` is ``None`` and a drain
  releases everything.
- Flush on idle: everything is released when nothing was offered for ``flush_idle`` s after the
  last callback (``end_callback``).
- Drain budget: one drain releases events for at most ``drain_budget`` s of the caller's clock.
Time enters only as arguments (``now`` of any monotonic clock, or a ``clock`` callable read between
events); stamps are integer nanoseconds.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from track_core.slam.hybrid import valid_observations

INPUT, SCAN = 'inputs', 'scan'
BEARING_TOLERANCE = 1e-6
"""[rad] bearings this far outside the limits are clipped, not dropped (float32 rounding): the node's default."""
_PRIORITY = {SCAN: 0, INPUT: 1}  # at equal stamps the scan first (victoria.events)
_OTHER = {INPUT: SCAN, SCAN: INPUT}

#: ``step(stream, t_ns, payload) -> bool``: feed one released event to the filter; False = the filter
#: refused it (state unchanged), so it does not count as processed.
Step = Callable[[str, int, Any], bool]
#: stream → the caller's clock when that stream last delivered a message, accepted or refused (pause rule).
Heard = Mapping[str, float | None] | None


class StreamMerger:
    """Watermark merge of the ``INPUT`` and ``SCAN`` streams (module docstring)."""

    def __init__(self, pause_wall: float, flush_idle: float, drain_budget: float, now: float) -> None:
        self.pause_wall, self.flush_idle, self.drain_budget = pause_wall, flush_idle, drain_budget
        self._heap: list = []
        self._seq = 0
        self.last_ns: dict[str, int | None] = {INPUT: None, SCAN: None}  # last accepted stamp per stream
        self._arrival: dict[str, float | None] = {INPUT: None, SCAN: None}  # when it was offered
        self._count = {INPUT: 0, SCAN: 0}  # events accepted per stream
        self._other_at = {INPUT: 0, SCAN: 0}  # the other stream's count at this one's last event
        self._first_arrival: float | None = None
        self.processed_ns: int | None = None  # stamp of the last event the filter took
        self.last_activity = now  # end of the last message callback that offered an accepted event
        self._seq_marked = 0  # _seq at that mark: a callback of refused messages only is no activity

    def reset(self, now: float) -> None:
        """Forget every buffered event, stamp and count: the clock jumped, a new run starts at ``now``."""
        self.__init__(self.pause_wall, self.flush_idle, self.drain_budget, now)

    def __len__(self) -> int:
        """Events buffered, not yet released."""
        return len(self._heap)

    def offer(self, stream: str, t_ns: int, payload: Any, now: float) -> str | None:
        """Buffer one event; the reason it is refused (nothing changes then), or None."""
        last = self.last_ns[stream]
        if last is not None and t_ns < last:
            return f'stamp {t_ns * 1e-9:.9f} s is before the previous one {last * 1e-9:.9f} s (time went backwards)'
        if self.processed_ns is not None and t_ns < self.processed_ns:
            return f'stamp {t_ns * 1e-9:.9f} s arrived after data up to {self.processed_ns * 1e-9:.9f} s was processed'
        self.last_ns[stream] = t_ns
        heapq.heappush(self._heap, (t_ns, _PRIORITY[stream], self._seq, stream, payload))
        self._seq += 1
        self._count[stream] += 1
        self._other_at[stream] = self._count[_OTHER[stream]]
        self._arrival[stream] = now
        if self._first_arrival is None:
            self._first_arrival = now
        return None

    def watermark(self, now: float, heard: Heard = None) -> int | None:
        """Stamp up to which nothing can still arrive; None when no stream bounds it (module docstring).
        ``heard``: stream → when it last delivered a message, accepted or refused (not silent then)."""
        limits = []
        for stream in (INPUT, SCAN):
            since = self._arrival[stream] if self._arrival[stream] is not None else self._first_arrival
            last_heard = (heard or {}).get(stream)
            if last_heard is not None and (since is None or last_heard > since):
                since = last_heard
            paused = (since is not None and now - since >= self.pause_wall
                      and self._count[_OTHER[stream]] - self._other_at[stream] >= 2)
            if paused:
                continue
            if self.last_ns[stream] is None:
                return None
            limits.append(self.last_ns[stream])
        return min(limits) if limits else None

    def drain(self, limit_ns: int | None, step: Step, clock: Callable[[], float]) -> int:
        """Release buffered events with stamp ≤ ``limit_ns`` (all when None) to ``step``, in (stamp, scan
        first) order, until ``drain_budget`` has passed on ``clock``; → the number released."""
        heap = self._heap
        deadline = clock() + self.drain_budget
        n = 0
        while heap and (limit_ns is None or heap[0][0] <= limit_ns) and clock() < deadline:
            t_ns, _, _, stream, payload = heapq.heappop(heap)
            n += 1
            if step(stream, t_ns, payload):
                self.processed_ns = t_ns
        return n

    def end_callback(self, step: Step, clock: Callable[[], float], heard: Heard = None) -> None:
        """After a message callback has offered everything queued: drain up to the watermark, mark activity."""
        self.drain(self.watermark(clock(), heard), step, clock)
        self._mark(clock())

    def _mark(self, now: float) -> None:
        """Activity at ``now`` if an event was accepted since the last mark (a flood of refused messages
        must neither change the state nor hold the idle flush back)."""
        if self._seq != self._seq_marked:
            self.last_activity, self._seq_marked = now, self._seq

    def on_idle(self, now: float, took: bool, step: Step, clock: Callable[[], float], heard: Heard = None) -> bool:
        """The periodic timer (``took``: it offered queued messages at ``now``): drain up to the watermark,
        or everything once idle for ``flush_idle``. → True when idle with nothing left buffered."""
        if took:
            self._mark(now)
        idle = now - self.last_activity >= self.flush_idle
        if self._heap:
            self.drain(None if idle else self.watermark(now, heard), step, clock)
        return idle and not self._heap


def input_ok(speed: float, steer: float) -> bool:
    """An input the vehicle model can take: finite values and |steering| < π/2."""
    return math.isfinite(speed) and math.isfinite(steer) and abs(steer) < math.pi / 2


def scan_observations(r: np.ndarray, b: np.ndarray, d: np.ndarray, bearing_limits: tuple[float, float],
                      tolerance: float, add_radius: bool, bound: float = math.inf) -> tuple[np.ndarray, np.ndarray]:
    """(z (m, 2) of (range, bearing) for the filter, mask of the usable rows of the scan).

    A row is usable by ``valid_observations`` with the limits widened by ``tolerance`` (float32
    rounding puts π at 3.1415927 > π) and, with ``add_radius``, a finite diameter ≥ 0; its bearing
    is clipped into the limits, and with ``add_radius`` the range is to the trunk centre,
    range + diameter/2 (as ``victoria.load``). A range (and with ``add_radius`` a diameter) above
    ``bound`` [m] is unusable too: a finite 1e308 would otherwise put a landmark at infinity.
    """
    lo, hi = bearing_limits
    ok = valid_observations(np.stack([r, b], axis=1), (lo - tolerance, hi + tolerance))
    with np.errstate(invalid='ignore'):
        ok &= np.abs(r) <= bound
        if add_radius:
            ok &= np.isfinite(d) & (d >= 0) & (d <= bound)
    rng = r[ok] + (0.5 * d[ok] if add_radius else 0.0)
    return np.stack([rng, np.clip(b[ok], lo, hi)], axis=1), ok
