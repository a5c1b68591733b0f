"""The observer's timing: sonar contacts and own-ship navigation as real streams give them, in filter steps.

A real sonar reports when it hears something, not on a grid; navigation comes on its own topic at its
own rate; either may be late or missing. ``ContactSequencer`` turns the two streams into the calls of
the SS-PF (``sspf.SSPF``):

- **A contact is a step at its own stamp.** The filter is predicted over the actual interval since its
  last step (eqs. 3–4 of any interval, ``SSPF.step(dt=...)``), then updated with the reading and the
  reading's own noise (``Contact.R``).
- **A missing contact is a predict-only step** (``SSPF.predict``, counted): before a contact that comes
  more than 1.5 periods T after the last step, the filter is predicted through the gap one period at a
  time, so the estimate and the eq. 7 request exist for every period. With ``coast_after`` > 0,
  ``tick`` also takes those steps while nothing comes (a sensor that stopped), once the node's clock is
  ``coast_after`` past the period that is due; a contact stamped before the filter's time after that is
  refused. Either way the predict-only steps fall on the same times (last step + j·T), so a replay that
  takes them on the next contact gives the same estimates as the live run that coasted.
- **The observer's position at the contact's stamp** is interpolated between the two navigation fixes
  around it; a contact waits (``held``) until a fix at or after its stamp has come, or until
  ``nav_wait`` has passed on the node's clock, and is then extrapolated from the last fix with its
  velocity if that fix is at most ``nav_max_age`` old; otherwise it is dropped with a reason. Waiting for
  the fix after the contact, not racing it, is what makes a replay reproduce the live run.
- **Refused, with a reason, changing nothing:** a contact not after the filter's time (or one already
  held), a fix older than the last fix.
- **The prior** (``SSPF.initialize``) describes the target one period T before the first contact.

Bearings. Contacts carry REP-103 angles (counter-clockwise from the x axis of their frame); a contact
in the ship's body frame (``relative``) is turned by the ship's heading at its stamp. The paper's
bearing is measured clockwise from north (``models.bearing``): b = π/2 − yaw, converted here, once.
Times are integer nanoseconds (message stamps), so "at or after" is exact.
"""

from __future__ import annotations

import math
from bisect import bisect_left
from collections import deque
from dataclasses import dataclass

import numpy as np

from track_core.filters import wrap_angle
from track_core.sonar.models import SensorMode, SonarParams, simulate_measurement
from track_core.sonar.sspf import SonarEstimate

MAX_FIXES = 4096  # navigation fixes kept (minutes of a 10 Hz navigation: contacts older than that are refused)
MAX_HELD = 64  # contacts waiting for navigation; one more is refused
GAP = 1.5  # a contact more than GAP periods after the last step: the periods between are predict-only steps
# An interval within SNAP_NS of the period is the period: stamps made as origin + k·T in float seconds and
# rounded to nanoseconds jitter by a few ns, and eqs. 3-4 of T are the ones the paper's runs use.
SNAP_NS = 1000


def bearing_of_yaw(yaw: float | np.ndarray) -> float | np.ndarray:
    """The paper's bearing (clockwise from north, wrapped to (−π, π]) of a REP-103 world yaw."""
    return wrap_angle(0.5 * math.pi - np.asarray(yaw, dtype=float))


def yaw_of_bearing(bearing: float | np.ndarray) -> float | np.ndarray:
    """The REP-103 world yaw (counter-clockwise from east, wrapped) of the paper's bearing."""
    return wrap_angle(0.5 * math.pi - np.asarray(bearing, dtype=float))


@dataclass(frozen=True)
class Contact:
    """One sonar reading: ``yaw`` [rad] REP-103 in its frame, ``range`` [m] when active, noise ``R``."""

    key: int  # stamp [ns]
    mode: SensorMode
    yaw: float
    range: float  # NaN when passive
    R: np.ndarray  # (1, 1) passive or (2, 2) active, in [rad², m²]
    relative: bool = False  # measured in the ship's body frame: add the ship's heading


def paper_reading(c: Contact, heading: float = 0.0) -> np.ndarray:
    """The reading z of eqs. 5–6 of a contact: [bearing] or [bearing, range], the bearing from north in the
    world frame (a relative contact turned by the ship's ``heading``, REP-103 yaw)."""
    b = float(bearing_of_yaw(c.yaw + heading if c.relative else c.yaw))
    return np.array([b, c.range]) if c.mode is SensorMode.ACTIVE else np.array([b])


def simulated_contact(rng: np.random.Generator, key: int, x_true: np.ndarray, observer_xy: np.ndarray,
                      mode: SensorMode, params: SonarParams, heading: float | None = None) -> Contact:
    """The eq. 5 or eq. 6 reading of the true state with Table 1's noise (``models.simulate_measurement``:
    the same draws), as a sonar reports it: a REP-103 yaw in the world frame, or in the ship's body frame
    when its ``heading`` is given."""
    z = simulate_measurement(rng, x_true, observer_xy, mode, params)
    yaw = float(yaw_of_bearing(z[0]))
    if heading is not None:
        yaw = float(wrap_angle(yaw - heading))
    r = float(z[1]) if mode is SensorMode.ACTIVE else math.nan
    return Contact(int(key), mode, yaw, r, params.R(mode), relative=heading is not None)


@dataclass(frozen=True)
class Fix:
    """One own-ship navigation fix in the world frame: position, velocity, heading (REP-103 yaw)."""

    key: int  # stamp [ns]
    xy: np.ndarray  # (2,) [m]
    velocity: np.ndarray  # (2,) [m/s]
    heading: float  # [rad]


@dataclass(frozen=True)
class Step:
    """One filter step: its stamp, the estimate, the observer position and the contact (None: predict-only)."""

    key: int
    estimate: SonarEstimate
    observer_xy: np.ndarray
    contact: Contact | None


@dataclass(frozen=True)
class Dropped:
    """A held contact given up: ``reason`` says why."""

    key: int
    reason: str


class Navigation:
    """The own ship's fixes, in stamp order, bounded: where the observer was at a stamp."""

    def __init__(self, max_fixes: int = MAX_FIXES) -> None:
        self.fixes: deque[Fix] = deque(maxlen=max_fixes)

    def problem(self, fix: Fix) -> str | None:
        if self.fixes and fix.key <= self.fixes[-1].key:
            return f'navigation stamp {fix.key} ns is not after the last fix ({self.fixes[-1].key} ns)'
        return None

    def add(self, fix: Fix) -> None:
        self.fixes.append(fix)

    def covers(self, key: int) -> bool:
        """A fix at or after ``key`` has come (the position there is an interpolation, not a guess)."""
        return bool(self.fixes) and self.fixes[-1].key >= key

    def at(self, key: int, max_age_ns: int) -> tuple[np.ndarray, float] | str:
        """(position, heading) at ``key``: interpolated between fixes, or extrapolated with the last fix's
        velocity when ``key`` is after it by at most ``max_age_ns``; else the reason there is none."""
        if not self.fixes:
            return 'no navigation fix yet'
        first, last = self.fixes[0], self.fixes[-1]
        if key >= last.key:
            age = key - last.key
            if age > max_age_ns:
                return (f'the last navigation fix is {age / 1e9:.3g} s before the contact '
                        f'(allowed {max_age_ns / 1e9:g} s)')
            return last.xy + last.velocity * (age / 1e9), last.heading
        if key < first.key:
            return f'the contact is older than the oldest navigation fix kept ({first.key} ns)'
        keys = [f.key for f in self.fixes]
        i = bisect_left(keys, key)
        b = self.fixes[i]
        if b.key == key:
            return b.xy, b.heading
        a = self.fixes[i - 1]
        s = (key - a.key) / (b.key - a.key)
        heading = a.heading + s * float(wrap_angle(b.heading - a.heading))
        return a.xy + s * (b.xy - a.xy), float(wrap_angle(heading))


class ContactSequencer:
    """Contacts and fixes in, SS-PF steps out (module docstring): the observer's state machine.

    ``tracker`` is an initialised ``SSPF`` (its prior one period before the first contact). Times are
    integer nanoseconds; ``now`` is the node's clock.
    """

    def __init__(self, tracker, period_ns: int, *, nav_wait_ns: int, nav_max_age_ns: int,
                 coast_after_ns: int = 0, max_held: int = MAX_HELD) -> None:
        if period_ns <= 0:
            raise ValueError(f'period_ns={period_ns}: must be > 0')
        self.tracker = tracker
        self.period_ns = int(period_ns)
        self.nav_wait_ns, self.nav_max_age_ns = int(nav_wait_ns), int(nav_max_age_ns)
        self.coast_after_ns = int(coast_after_ns)
        self.max_held = int(max_held)
        self.nav = Navigation()
        self.key: int | None = None  # the filter's time (stamp of its last step); None before the first contact
        self.held: list[tuple[Contact, int]] = []  # (contact, node time it arrived), in stamp order
        self.updates = 0

    @property
    def predictions(self) -> int:
        return self.tracker.predictions

    # -- inputs ---------------------------------------------------------------------------
    def contact_problem(self, c: Contact) -> str | None:
        """Why ``c`` cannot be taken, or None; nothing is changed."""
        if self.key is not None and c.key <= self.key:
            return f'stamp {c.key} ns is not after the filter time {self.key} ns (late or out of order)'
        if any(h.key == c.key for h, _ in self.held):
            return f'a contact stamped {c.key} ns is already waiting for navigation'
        if len(self.held) >= self.max_held:
            return f'{self.max_held} contacts are already waiting for navigation (is it running?)'
        return None

    def add_contact(self, c: Contact, now: int) -> list[Step | Dropped]:
        """Hold a contact that has no ``contact_problem``; the steps now possible."""
        self.held.append((c, int(now)))
        self.held.sort(key=lambda h: h[0].key)
        return self._drain(now)

    def add_fix(self, fix: Fix, now: int) -> list[Step | Dropped]:
        """Take a fix that has no ``nav.problem``; the steps now possible."""
        self.nav.add(fix)
        return self._drain(now)

    def tick(self, now: int) -> list[Step | Dropped]:
        """Held contacts whose wait for navigation is over, then predict-only steps while nothing comes."""
        out = self._drain(now)
        if self.coast_after_ns > 0 and self.key is not None and not self.held:
            while now >= self.key + self.period_ns + self.coast_after_ns:
                out.append(self._predict(self.key + self.period_ns))
        return out

    # -- steps ----------------------------------------------------------------------------
    def _drain(self, now: int) -> list[Step | Dropped]:
        out: list[Step | Dropped] = []
        while self.held:
            c, arrived = self.held[0]
            if not self.nav.covers(c.key) and now - arrived < self.nav_wait_ns:
                break  # the fix after it may still come
            self.held.pop(0)
            where = self.nav.at(c.key, self.nav_max_age_ns)
            if isinstance(where, str):
                out.append(Dropped(c.key, where))
                continue
            out.extend(self._update(c, *where))
        return out

    def _update(self, c: Contact, obs_xy: np.ndarray, heading: float) -> list[Step]:
        out = []
        if self.key is not None:
            while c.key - self.key > GAP * self.period_ns:
                out.append(self._predict(self.key + self.period_ns))
        dt_ns = self.period_ns if self.key is None else c.key - self.key
        if abs(dt_ns - self.period_ns) <= SNAP_NS:
            dt_ns = self.period_ns
        est = self.tracker.step(paper_reading(c, heading), c.mode, obs_xy, dt=dt_ns / 1e9, R=c.R)
        self.key = c.key
        self.updates += 1
        out.append(Step(c.key, est, np.asarray(obs_xy, dtype=float), c))
        return out

    def _predict(self, key: int) -> Step:
        where = self.nav.at(key, self.nav_max_age_ns)
        obs = where[0] if not isinstance(where, str) else np.full(2, np.nan)
        est = self.tracker.predict((key - self.key) / 1e9)
        self.key = key
        return Step(key, est, obs, None)
