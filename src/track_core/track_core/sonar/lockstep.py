"""The lock-step of the sonar scenario: when each node may take its step k (pure state machines, no ROS).

The closed loop of ``experiments.run_closed_loop`` alternates target step k (x_{k-1} → x_k, using
the observer's ping and position at t_{k-1}) and the reading of x_k. Three nodes run it: the smart
target, the simulated sonar (``sonar_sim``: the observer's route, its pings, its readings) and the
estimator (``sonar_observer``, which only sees the readings and the navigation). Over messages that
arrive in any order, the two simulators keep the alternation with these gates; they work on integer
stamp keys (the nanoseconds of the message stamps), so "the message of t_k" is an exact comparison:

- ``TruthGate`` (the simulated sonar): the target's truth sets the time. The first truth accepted is
  step 1 and fixes the step grid (that stamp + j·T); step j is taken when the truth of grid point j
  has arrived, strictly in order, and carries that truth's own stamp. No clock origin is shared by
  convention, so the nodes can be started in any order, any time apart.
- ``CommandGate`` (the simulated sonar): step k's reading waits for the observer's request made after
  its step k−1 (``SonarModeCommand`` stamped t_{k-1}), so the sonar pings when the filter asked.
- ``TargetGate`` (the smart target): step k is taken when its time has come and, with
  ``sync_observer``, the observer's navigation stamped t_{k-1} has arrived (the sonar publishes its
  ping before the navigation, so the ping of t_{k-1} is known by then). Without it, step k takes
  a ping of t_{k-1} only if it has arrived, and the latest observer position.

The target's step k waits for the sonar's step k−1, the sonar's step k for the target's step k and
the estimator's step k−1, and the estimator for nothing but readings, so the loop cannot deadlock.
"""

from __future__ import annotations

from collections import deque

import numpy as np

from track_core.sonar.models import SensorMode

WINDOW = 64  # truths held ahead of the next step; a stamp further ahead is refused


class TruthGate:
    """The observer's side: truths by step j on the grid of the first accepted one, taken in order.

    A truth is refused (``problem``), and changes nothing, when it is off the grid (more than T/4
    from a grid point), of a step already taken or held, or more than ``WINDOW`` steps ahead.
    """

    def __init__(self, period_ns: int) -> None:
        if period_ns <= 0:
            raise ValueError(f'period_ns={period_ns}: must be > 0')
        self.period_ns = int(period_ns)
        self.first_key: int | None = None
        self.next = 1  # the step to take next
        self.truth: dict[int, tuple[int, np.ndarray]] = {}  # held: step j → (stamp key, state)
        self._stall_reported = False

    def step_of(self, key: int) -> int:
        """The grid step of stamp ``key`` (1 for the first truth)."""
        return 1 if self.first_key is None else 1 + round((key - self.first_key) / self.period_ns)

    def key_of(self, j: int) -> int | None:
        return None if self.first_key is None else self.first_key + (j - 1) * self.period_ns

    def problem(self, key: int) -> str | None:
        """Why the truth stamped ``key`` [ns] cannot be taken, or ``None``; the gate is not changed."""
        if self.first_key is None:
            return None
        j = self.step_of(key)
        if abs(key - self.key_of(j)) > self.period_ns // 4:
            return (f'stamp {key} ns is off the step grid of the first truth ({self.first_key} ns + j x '
                    f'{self.period_ns} ns): was smart_target restarted? restart the observer too')
        if j < self.next or j in self.truth:
            return f'step {j} (stamp {key} ns) was already received'
        if j >= self.next + WINDOW:
            return f'step {j} is more than {WINDOW} steps ahead of the next one, {self.next}'
        return None

    def add_truth(self, key: int, x: np.ndarray) -> list[tuple[int, int, np.ndarray]]:
        """Take a truth that has no ``problem``; the steps now ready, in order: (step j, stamp key, state)."""
        if self.first_key is None:
            self.first_key = int(key)
        self.truth[self.step_of(key)] = (int(key), x)
        out = []
        while self.next in self.truth:
            k, xj = self.truth.pop(self.next)
            out.append((self.next, k, xj))
            self.next += 1
            self._stall_reported = False
        return out

    def stalled(self) -> int | None:
        """Once per gap: the stamp key of the missing step when more than two later truths wait for it."""
        if self._stall_reported or len(self.truth) <= 2:
            return None
        self._stall_reported = True
        return self.key_of(self.next)


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


class CommandGate:
    """The sonar simulator's side: step k's reading obeys the observer's request made after step k−1.

    ``lockstep`` (deterministic runs): the reading of step k waits for the request stamped t_{k-1}
    (the first step for any request, the observer's start request stamped 0 among them), so the
    simulated sonar pings exactly when the filter asked. Without it, a step takes the latest request
    received, or ``initial`` before any, like a real sonar driver. ``force`` takes the waiting step
    with the latest request (the observer is gone: the caller's timeout).
    """

    def __init__(self, lockstep: bool, initial: SensorMode) -> None:
        self.lockstep = bool(lockstep)
        self.initial = initial
        self.commands: dict[int, SensorMode] = {}  # request stamp key → mode
        self.latest: tuple[int, SensorMode] | None = None  # the request with the largest stamp
        self.pending: deque[tuple[int, int, np.ndarray]] = deque()  # steps due: (k, stamp key, truth)
        self.prev_key: int | None = None  # stamp of the last step taken

    def add_step(self, k: int, key: int, x: np.ndarray) -> list[tuple[int, int, np.ndarray, SensorMode]]:
        self.pending.append((k, key, x))
        return self._ready()

    def add_command(self, key: int, mode: SensorMode) -> list[tuple[int, int, np.ndarray, SensorMode]]:
        self.commands[key] = mode
        if self.latest is None or key >= self.latest[0]:
            self.latest = (key, mode)
        return self._ready()

    def waiting(self) -> int | None:
        """The stamp key of the request the next step waits for (lockstep), else None."""
        if not (self.lockstep and self.pending):
            return None
        return -1 if self.prev_key is None else self.prev_key

    def force(self) -> list[tuple[int, int, np.ndarray, SensorMode]]:
        """Take the first waiting step with the latest request (or ``initial``), then whatever is ready."""
        if not self.pending:
            return []
        return [self._take(self.latest[1] if self.latest else self.initial), *self._ready()]

    def _ready(self) -> list[tuple[int, int, np.ndarray, SensorMode]]:
        out = []
        while self.pending:
            if not self.lockstep:
                mode = self.latest[1] if self.latest else self.initial
            elif self.prev_key is None:
                if self.latest is None:
                    break
                mode = self.latest[1]
            elif self.prev_key in self.commands:
                mode = self.commands[self.prev_key]
            else:
                break  # the observer's request after the last step has not come yet
            out.append(self._take(mode))
        return out

    def _take(self, mode: SensorMode) -> tuple[int, int, np.ndarray, SensorMode]:
        k, key, x = self.pending.popleft()
        self.prev_key = key
        self.commands = {c: m for c, m in self.commands.items() if c >= key}
        return k, key, x, mode
