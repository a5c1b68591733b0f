"""The lock-step of the sonar node pair: when each side may take its step k (pure state machines, no ROS).

The closed loop of ``experiments.run_closed_loop`` alternates target step k (x_{k-1} → x_k, using
the observer's ping and position at t_{k-1}) and observer step k (measuring x_k). Over messages
that arrive in any order, each node keeps the alternation with one of these gates; both work on
integer stamp keys (the nanoseconds of the message stamps), so "the message of t_k" is an exact
comparison:

- ``TruthGate`` (the observer): step k is taken when both its time has come and the truth
  stamped t_k has arrived, whichever is second; steps strictly in order.
- ``TargetGate`` (the smart target): step k is taken when its time has come and, with
  ``sync_observer``, the observer's Odometry stamped t_{k-1} has arrived (the observer publishes
  its ping before its Odometry, so the ping of t_{k-1} is known by then). Without it, step k takes
  a ping of t_{k-1} only if it has arrived, and the latest observer position.

The target's step k never waits for the observer's step k (only k−1), so the pair cannot deadlock.
"""

from __future__ import annotations

from collections import deque

import numpy as np


class TruthGate:
    """The observer's side: due step times (t, key) waiting for the truth stamped with that key."""

    def __init__(self) -> None:
        self.pending: deque[tuple[float, int]] = deque()
        self.truth: dict[int, np.ndarray] = {}
        self._stall_reported = False

    def due(self, t: float, key: int) -> list[tuple[float, np.ndarray]]:
        """Step time t (stamp key ``key``) has come; the steps now ready, in order: (t, truth state)."""
        self.pending.append((t, key))
        return self._ready()

    def add_truth(self, key: int, x: np.ndarray) -> list[tuple[float, np.ndarray]]:
        self.truth[key] = x
        return self._ready()

    def stalled(self) -> float | None:
        """Once: the time of the oldest step when more than two wait for their truth (else None)."""
        if self._stall_reported or len(self.pending) <= 2 or self.pending[0][1] in self.truth:
            return None
        self._stall_reported = True
        return self.pending[0][0]

    def _ready(self) -> list[tuple[float, np.ndarray]]:
        out = []
        while self.pending and self.pending[0][1] in self.truth:
            t, key = self.pending.popleft()
            out.append((t, self.truth.pop(key)))
            self.truth = {k: v for k, v in self.truth.items() if k > key}
        return out


class TargetGate:
    """The smart target's side: due steps, the observer's pings and positions by stamp key."""

    def __init__(self, sync_observer: bool, keep_ns: int) -> None:
        self.sync = bool(sync_observer)
        self.keep_ns = int(keep_ns)  # pings/positions older than t_k − keep_ns are dropped after step k
        self.pending: deque[tuple[float, int]] = deque()
        self.pings: dict[int, np.ndarray] = {}
        self.observer: dict[int, np.ndarray] = {}
        self.last_key: int | None = None  # key of t_{k-1}; None before step 1

    def due(self, t: float, key: int) -> list[tuple[float, bool, np.ndarray]]:
        """Step time t has come; the steps now ready, in order: (t, pinged at t_{k-1}, observer at t_{k-1})."""
        self.pending.append((t, key))
        return self._ready()

    def add_ping(self, key: int, xy: np.ndarray) -> None:
        self.pings[key] = xy

    def add_observer(self, key: int, xy: np.ndarray) -> list[tuple[float, bool, np.ndarray]]:
        self.observer[key] = xy
        return self._ready()

    def observer_at(self, key: int | None) -> np.ndarray:
        """Observer position at t_{k-1}: its Odometry, else its ping, else the latest one before."""
        if key is not None and key in self.observer:
            return self.observer[key]
        if key is not None and key in self.pings:
            return self.pings[key]
        older = [k for k in self.observer if key is None or k <= key]
        return self.observer[max(older)] if older else np.zeros(2)  # none yet (step 1): no ping, no evasion

    def _ready(self) -> list[tuple[float, bool, np.ndarray]]:
        out = []
        while self.pending:
            key = self.last_key
            if self.sync and key is not None and key not in self.observer:
                break  # the observer's step at t_{k-1} is not known yet
            pinged = key is not None and key in self.pings
            obs = self.observer_at(key)
            t, self.last_key = self.pending.popleft()
            cutoff = self.last_key - self.keep_ns  # keep what t_k and t_{k+1} may still need
            self.pings = {k: v for k, v in self.pings.items() if k >= cutoff}
            self.observer = {k: v for k, v in self.observer.items() if k >= cutoff}
            out.append((t, pinged, obs))
        return out
