"""One sensor's side of the IDSQ leader protocol, as a pure state machine (no ROS, no clock).

``HandoffLedger`` is what an ``acoustic_sensor`` / ``doa_sensor`` node decides; the node only
converts messages, keeps the endpoints and the steady-clock timers, and carries out the effects
each call returns (``Reply``, ``Send``, ``Disarm``, ``Led``, ``Reselect``, ``SelfLead``, ``Log``),
in order. Protocol: Table 1 of Liu, Reich, Zhao 2002, one leader at a time.

- ``on_handoff``: ``validate_handoff`` checks a ``handoff.Handoff`` (or gets ``handoff.Unusable``);
  it is refused (a nack with the reason; only ``refused`` changes) when bad, *busy* (a belief held),
  *stale* (a later step led), *window* (over ``STEP_WINDOW`` from ``horizon``) or *expired*
  (``age`` over ``ack_timeout``). ``reading_problem`` refuses readings ``READING_WINDOW`` ahead.
- ``on_reading``: z of eq. 6 (amplitude) or eq. 11 (bearing θ, clockwise from north), buffered.
  The belief p(x⁽ᵗ⁾|z̄⁽ᵗ⁾) is held until the reading of t + 1 is in; ``leader_step`` then diffuses,
  updates, scores each neighbour but the previous leader by MI and hands on (``Led``, ``Send``).
- ``reading_missed`` (beyond the paper): after ``reading_timeout`` the step is led predict-only
  (eq. 3 with no z; ``missed``); a reading that comes later is dropped (``late``).
- Start (§5.1): ``on_election`` gathers every sensor's step-0 amplitude, ``elected`` picks the
  loudest acoustic sensor (``election_timeout`` decides on those heard, ``unheard``);
  ``SensorSetup.start`` = 'election' also updates the step-0 belief with the neighbours' amplitudes.
- ``timeout`` / a nack re-send to the next of ``handoff_order`` (by decreasing MI, then the
  previous leader, then itself: the track never stops).
- One chain: the sender decides. An ack from a receiver it no longer vouches for gets a ``Revoke``;
  ``on_revoke`` drops or voids (``Void``) the revoked belief and revokes downstream.
- The reading of step s is stamped (s + 1)·Δt, like every leader output of step s. Randomness:
  ``SeedSequence(seed, spawn_key=(3, k, s))`` for a simulated reading, ``(4, k, s)`` for the
  ``random`` baseline (keys 0-2 are the core experiments').
Why each rule: docs/MODULES.md, "The IDSQ leader protocol"; measured: docs/results/idsq.md.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from track_core.idsq.config import STARTS, LeaderConfig
from track_core.idsq.grid import GridSpec, SparseBelief, uniform_belief
from track_core.idsq.handoff import (
    Handoff,
    Revocation,
    Unusable,
    decode_handoff,
    encode_handoff,
    encode_revoke,
    read_package,
    validate_handoff,
)
from track_core.idsq.models import SimNoise, TrackerParams, loudest_source
from track_core.idsq.network import SensorLayout, start_leader
from track_core.idsq.network import handoff_targets as core_handoff_targets
from track_core.idsq.readings import MEASUREMENT_KEY, as_received, field_readings, measurement_normal, sensor_reading
from track_core.idsq.simulation import scenario_of
from track_core.idsq.tracker import LeaderStepResult, leader_step, update

__all__ = ['MEASUREMENT_KEY', 'measurement_normal']  # (re-exported: the draws' home is readings.py)
SELECTION_KEY = 4
MAX_READINGS = 4096  # buffered reading steps per sensor (the §5.1 track has 72)
STEP_WINDOW = 256  # a handoff's step is within this many steps of the sensor's horizon (the reading QoS depth)
READING_WINDOW = MAX_READINGS  # a reading at most this many steps after the horizon (an absurd stamp is a huge step)


# --- time, randomness, start, order ------------------------------------------------------------

def stamp_of_step(step: int, dt: float, origin: float = 0.0) -> float:
    """Time [s] of tracker step ``step``: origin + (step + 1)·Δt (the first tick is one period after the origin).

    The origin is the stamp of the sensor layout (``vehicle_sim``'s clock origin): the whole second of
    node time when it started (the launcher's ``--epoch`` on /clock), so the field needs no clock origin
    shared by convention.
    """
    return origin + (int(step) + 1) * dt


def step_of_stamp(t: float, dt: float, origin: float = 0.0) -> int | None:
    """Tracker step of a reading's stamp, or ``None`` when ``t`` is not origin + (s + 1)·Δt for an s >= 0."""
    s = round((t - origin) / dt) - 1
    return s if s >= 0 and abs(stamp_of_step(s, dt, origin) - t) <= 1e-6 else None


def selection_rng(seed: int, sensor: int, step: int) -> np.random.Generator:
    """Generator of the ``random`` selection baseline for ``sensor`` leading ``step``."""
    return np.random.default_rng(np.random.SeedSequence(int(seed), spawn_key=(SELECTION_KEY, int(sensor), int(step))))


loudest = loudest_source  # (sources (2,) or (M, 2), sensor (2,)) → the nearest source: what the sensor hears




def start_belief(layout: SensorLayout, leader: int, amplitudes: np.ndarray, grid: GridSpec, p: TrackerParams,
                 start: str = 'uniform') -> SparseBelief:
    """The belief the start leader leads step 0 from: 'uniform' (§5.1), or 'election' (module docstring):
    the uniform belief updated (``tracker.update``, eq. 6) with the step-0 amplitude reading of each
    radio neighbour of ``leader`` (``SensorLayout.neighbours``; ``amplitudes`` (K,), NaN where the
    election did not hear one: left out)."""
    if start not in STARTS:
        raise ValueError(f'start={start!r} must be one of {STARTS}')
    belief = uniform_belief(grid)
    if start == 'uniform':
        return belief
    for k in np.asarray(layout.neighbours[leader]).tolist():
        if np.isfinite(amplitudes[k]):
            belief, _ = update(belief, float(amplitudes[k]), layout.positions[k], False, p)
    return belief


def elected(layout: SensorLayout, amplitudes: np.ndarray) -> int | None:
    """§5.1 start leader (``network.start_leader``) from the step-0 amplitudes (K,) the election heard,
    NaN for a sensor not heard (it cannot win); ``None`` when none was heard."""
    amp = np.asarray(amplitudes, dtype=float)
    if not np.isfinite(amp).any():
        return None
    return start_leader(layout, np.where(np.isfinite(amp), amp, -np.inf))


def start_amplitudes(layout: SensorLayout, truth0: np.ndarray, noise: SimNoise, seed: int) -> np.ndarray:
    """(K,) every sensor's simulated step-0 amplitude (``readings.field_readings``): what the election hears."""
    return np.array([r.amplitude for r in field_readings(truth0, layout, 0, noise, seed)])


def start_leader_of(layout: SensorLayout, truth0: np.ndarray, noise: SimNoise, seed: int) -> int:
    """§5.1 start as the sensors decide it on the simulated step-0 amplitudes. ``truth0``: one source (2,)
    or several (M, 2), each sensor hears its loudest."""
    return start_leader(layout, start_amplitudes(layout, truth0, noise, seed))


def protocol_track(seed: int, n_sensors: int, n_steps: int, doa_fraction: float = 0.3,
                   cell: float = LeaderConfig.cell,
                   tracker: TrackerParams | None = None,
                   noise: SimNoise | None = None) -> tuple[np.ndarray, np.ndarray, list[int]]:
    """The track a network of nodes must publish, computed with the core alone: (means (T, 2),
    covariances (T, 2, 2), leader of each step) of the ``scenario_of(seed, n_sensors, doa_fraction)``
    field, each step led by ``leader_step`` with the simulator's per-(sensor, step) readings as the
    leader receives them (``readings.as_received``: the REP-103 round trip of a bearing) and handed on
    as the float32 body a node receives (``decode_handoff``). No ack is lost, no reading is missing and
    no leader fails: what a network with one process per sensor, on any number of hosts, records bit for bit."""
    sc, layout, truth = scenario_of(seed, n_sensors, doa_fraction)
    tp, noise = tracker or TrackerParams(), noise or SimNoise()
    belief = uniform_belief(GridSpec.for_field(sc.width, sc.height, cell))
    leader, prev = start_leader_of(layout, truth[0], noise, seed), None
    means, covs, leaders = [], [], []
    for s in range(n_steps):
        r = sensor_reading(truth[s], layout.positions[leader], bool(layout.is_doa[leader]), leader, s, noise, seed)
        out = leader_step(belief, received_z(r), leader, layout, tp, step=s, previous=prev)
        means.append(out.estimate.mean)
        covs.append(out.estimate.cov)
        leaders.append(leader)
        belief = decode_handoff(out.payload).belief()
        prev, leader = leader, out.next_leader
    return np.array(means), np.array(covs), leaders


def received_z(r) -> float:
    """The z a sensor leads with from the simulated reading ``r`` (``readings.Reading``), as the message gives it."""
    return as_received(r.bearing) if r.is_doa else r.amplitude


def handoff_targets(layout: SensorLayout, k: int) -> set[int]:
    """Every sensor ``k`` may hand off to (the core's ``network.handoff_targets``), as a set."""
    return set(core_handoff_targets(layout, k).tolist())


def handoff_order(cands: np.ndarray, scores: np.ndarray, neighbours: np.ndarray, previous: int | None,
                  me: int, first: int | None = None, last: set[int] | frozenset = frozenset()) -> list[int]:
    """Who to try, in order: ``first`` (the core's choice), the other candidates by decreasing score,
    those in ``last`` (suspected dead) after them, then the previous leader if it is a neighbour,
    and ``me`` at the end (the leader keeps the track)."""
    ranked = [int(c) for c in np.asarray(cands)[np.argsort(-np.asarray(scores, dtype=float), kind='stable')]]
    if first is not None and first in ranked:
        ranked.remove(first)
        ranked.insert(0, first)
    ranked = [c for c in ranked if c not in last] + [c for c in ranked if c in last]
    if previous is not None and previous != me and previous in set(np.asarray(neighbours).tolist()) \
            and previous not in ranked:
        ranked.append(int(previous))
    return [*ranked, me]


def layout_problem(layout: SensorLayout, me: int, position: np.ndarray, is_doa: bool) -> str | None:
    """Why sensor ``me`` (at ``position``, of type DOA or not) disagrees with ``layout``, else ``None``."""
    if me >= layout.n:
        return f'id={me} is not in the layout of {layout.n} sensors'
    if not np.allclose(layout.positions[me], position, rtol=0.0, atol=1e-6):
        return f'position={np.asarray(position).tolist()} differs from the layout entry {layout.positions[me].tolist()}'
    if bool(layout.is_doa[me]) != is_doa:
        return f'type={"doa" if is_doa else "acoustic"} differs from the layout entry (DOA={bool(layout.is_doa[me])})'
    return None


# --- effects: what the node carries out, in order -------------------------------------------------

@dataclass(frozen=True)
class Reply:
    """Answer ``sender``'s handoff of ``step``: an ack (``refusal`` None) or a nack with the reason."""

    sender: int
    step: int
    refusal: str | None


@dataclass(frozen=True)
class Send:
    """Publish ``handoff`` to ``receiver`` and arm its ack timer for (``step``, ``receiver``); ``payload``
    is its package bytes (their length is the size we report)."""

    step: int
    receiver: int
    payload: bytes
    handoff: Handoff | None = None


@dataclass(frozen=True)
class Disarm:
    """Cancel the ack timer of (``step``, ``receiver``)."""

    step: int
    receiver: int


@dataclass(frozen=True)
class Led:
    """This sensor led ``step`` (publish the estimate, belief, markers and the ``step`` event)."""

    step: int
    previous: int | None
    z: float
    result: LeaderStepResult
    next: int  # first sensor of the handoff order (this sensor when no neighbour is left)


@dataclass(frozen=True)
class Reselect:
    """The handoff of ``step`` goes to ``receiver`` after ``failed`` timed out or refused (``reason``)."""

    step: int
    receiver: int
    failed: int
    reason: str
    handoff_bytes: int


@dataclass(frozen=True)
class SelfLead:
    """No neighbour took the handoff of ``step`` (``tried``): this sensor leads step + 1 itself."""

    step: int
    tried: tuple[int, ...]


@dataclass(frozen=True)
class Log:
    """One log line (``level`` ``info`` or ``warning``)."""

    level: str
    text: str
    refusal: tuple[str, str] | None = None  # (handoff, ack or revoke: its channel, reason), for the node's refuse


@dataclass(frozen=True)
class Revoke:
    """Revoke this sensor's handoff of ``step`` to ``receiver`` (``payload``: the revoke's bytes), no
    timer; log ``text``."""

    step: int
    receiver: int
    payload: bytes
    text: str


@dataclass(frozen=True)
class Void:
    """This sensor's lead of ``step`` (its belief from ``parent``) was revoked: its chain ends here."""

    step: int
    parent: int | None


Effect = Reply | Send | Disarm | Led | Reselect | SelfLead | Log | Revoke | Void


@dataclass
class Pending:
    """A belief p(x⁽ᵗ⁻¹⁾|z̄) waiting for the reading of ``step`` = t, to be led by this sensor."""

    belief: SparseBelief
    step: int
    previous: int | None
    parent: int | None = None  # whose handoff it is: the sender, this sensor after a self-lead, None at the start


@dataclass
class Outgoing:
    """The posterior of ``step`` being handed off: who is tried now and who is left."""

    step: int
    belief: SparseBelief
    order: list[int]
    receiver: int | None = None
    tried: list[int] = field(default_factory=list)


@dataclass(frozen=True)
class SensorSetup:
    """What the ledger needs to know about its sensor and the tracker."""

    me: int
    position: np.ndarray
    is_doa: bool
    grid: GridSpec
    tracker: TrackerParams
    seed: int = 0  # of the ``random`` selection baseline (``selection_rng``)
    selection: str = LeaderConfig.selection
    ack_timeout: float = LeaderConfig.ack_timeout  # only named in the timeout warning; the node's timer measures it
    start: str = LeaderConfig.start  # the start leader's belief at step 0 (``start_belief``)
    reading_timeout: float = LeaderConfig.reading_timeout  # only named in the warnings; the node's timers measure it

    @classmethod
    def of(cls, me: int, position: np.ndarray, is_doa: bool, config: LeaderConfig, seed: int = 0) -> SensorSetup:
        """Sensor ``me``'s setup from the one configuration (``config.LeaderConfig``)."""
        c = config
        return cls(me, position, is_doa, c.grid, c.tracker, seed, c.selection, c.ack_timeout, c.start,
                   c.reading_timeout)


class HandoffLedger:
    """The pending belief, the outgoing handoffs per step, suspects and the refusal rules of one sensor.

    Every input method returns the effects to carry out, in order; ``timeout(step, receiver)`` is
    called by the node's timer of a ``Send``.
    """

    def __init__(self, setup: SensorSetup) -> None:
        self.s = setup
        self.me = setup.me
        self.layout: SensorLayout | None = None
        self.readings: dict[int, float] = {}  # step → this sensor's z (eq. 6 amplitude or eq. 11 bearing θ)
        self.election: dict[int, float] = {}  # sensor → its step-0 amplitude, as heard
        self.missed: list[int] = []  # steps led predict-only: no reading within the timeout
        self.late = self.unheard = 0  # readings after their step was led without them; sensors the election missed
        self.inbox: list[tuple[Handoff | Unusable | Revocation, float | None]] = []
        self.pending: Pending | None = None
        self.outgoing: dict[int, Outgoing] = {}  # step → handoff awaiting its ack (several if acks lag)
        self.start_checked = False
        self.last_led = -1
        self.led: list[int] = []  # steps this sensor led, the last STEP_WINDOW steps (a run of days stays bounded)
        self.suspects: set[int] = set()
        self.refused = self.timeouts = self.nacks = 0
        # the chain rule (module docstring), for the last STEP_WINDOW led steps:
        self.sent: dict[int, list[int]] = {}  # step → every receiver its handoff was sent to
        self.handed: dict[int, int] = {}  # step → who took it in time (this sensor after a self-lead)
        self.parent: dict[int, int | None] = {}  # led step → whose handoff its belief was
        self.void: set[int] = set()  # led steps revoked since
        self.revokes = 0  # revokes sent

    # -- inputs ------------------------------------------------------------------------------------
    def set_layout(self, layout: SensorLayout) -> list[Effect]:
        """The (checked, see ``layout_problem``) network layout: the sensor starts working."""
        self.layout = layout
        return self.advance()

    def on_reading(self, step: int, z: float, amplitude: float = float('nan')) -> list[Effect]:
        """This sensor's reading of ``step``: ``z`` (eq. 6 amplitude, or for a DOA sensor the eq. 11 bearing θ,
        clockwise from north) and its ``amplitude`` (both types; at step 0 this sensor's own election entry)."""
        if step in self.readings:
            return []  # a repeated reading does not change the one held
        if step in self.missed:
            self.late += 1
            why = f'late: the reading of step {step} came after the step was led without it'
            return [Log('warning', f'{why}; dropped', ('reading', why))]
        self.readings[step] = float(z)
        if len(self.readings) > MAX_READINGS:
            del self.readings[min(self.readings)]
        if step == 0 and np.isfinite(amplitude):
            self.election.setdefault(self.me, float(amplitude))
        return self.advance()

    def on_field(self, readings: list) -> list[Effect]:
        """One step of a whole field's readings (``readings.Reading``, as ``FieldSimulator`` gives them):
        what this sensor's node receives of them, the others' step-0 amplitudes (the election) first,
        then its own reading (its bearing after the message's round trip, ``received_z``)."""
        fx: list[Effect] = []
        for r in readings:
            if r.step == 0 and r.sensor != self.me:
                fx += self.on_election(r.sensor, r.amplitude)
        for r in readings:
            if r.sensor == self.me:
                fx += self.on_reading(r.step, received_z(r), r.amplitude)
        return fx

    def on_election(self, sensor: int, amplitude: float) -> list[Effect]:
        """Sensor ``sensor``'s step-0 amplitude, as it told the field (the first one heard counts)."""
        if sensor in self.election or not np.isfinite(amplitude):
            return []
        self.election[int(sensor)] = float(amplitude)
        return self.advance()

    def election_timeout(self) -> list[Effect]:
        """The node's election timer expired: decide the start on the amplitudes heard (module docstring)."""
        if self.start_checked or self.layout is None or not self.election:
            return []
        self.unheard = self.layout.n - sum(1 for k in self.election if k < self.layout.n)
        return [Log('warning', f'election: {self.unheard} of {self.layout.n} step-0 amplitudes not heard within '
                               f'{self.s.reading_timeout:g} s; deciding on the others'), *self.advance(True)]

    def reading_missed(self, step: int) -> list[Effect]:
        """The node's reading timer of ``step`` expired: lead it predict-only if still waiting for it."""
        if self.layout is None or self.pending is None or self.pending.step != step or step in self.readings:
            return []
        pend, self.pending = self.pending, None
        self.missed.append(step)
        del self.missed[:-STEP_WINDOW]
        return [Log('warning', f'no reading of step {step} within {self.s.reading_timeout:g} s: leading it '
                               'predict-only (diffused, no update)'), *self._lead(pend), *self.advance()]

    def waiting_for(self) -> int | None:
        """The step whose reading this sensor waits for to lead it (the node times it), else ``None``."""
        if self.layout is None or self.pending is None or self.pending.step in self.readings:
            return None
        return self.pending.step

    def horizon(self) -> int:
        """The latest step this sensor knows of: a reading, led or pending (-1 before any)."""
        return max(max(self.readings, default=-1), self.last_led, -1 if self.pending is None else self.pending.step)

    def reading_problem(self, step: int | None, t: float, dt: float) -> str | None:
        """Why a reading stamped ``t`` (``step`` = ``step_of_stamp(t, dt)``) is refused: not on a step, or
        too far after the horizon (an absurd stamp is a huge step); else ``None``."""
        if step is None:
            return f'header.stamp: {t:.9f} s is not (s + 1)·dt for dt={dt} s'
        h = self.horizon()
        if step > h + READING_WINDOW:
            return f'step: reading of step {step} is more than {READING_WINDOW} after step {h}'
        return None

    def on_handoff(self, item: Handoff | Unusable | Revocation | bytes, age: float | None = None) -> list[Effect]:
        """A received handoff (``Unusable`` when it did not read; package bytes are read with
        ``read_package``, a revoke included); ``age`` [s]: how long after its publication it came."""
        self.inbox.append((read_package(item) if isinstance(item, bytes) else item, age))
        return self.advance()

    def on_revoke(self, sender: int, receiver: int, step: int) -> list[Effect]:
        """``sender`` revokes its handoff of ``step`` to ``receiver`` (the chain rule, module docstring)."""
        self.inbox.append((Revocation(sender, receiver, step), None))
        return self.advance()

    def on_reply(self, step: int, sender: int, receiver: int, result: str, message: str = '') -> list[Effect]:
        """One ack (``result`` ``ack``) or nack (anything else, ``message`` the reason) from ``receiver``.
        The node calls ``advance`` once after all replies of a message."""
        out = self.outgoing.get(step)
        if sender != self.me:
            return []
        if out is None or out.receiver != receiver:
            fx = [Log('warning', f'late {result} from sensor {receiver} for the handoff of step {step} '
                                 'ignored (already re-selected or done)',
                      ('ack', f'late reply: {result} from sensor {receiver} for step {step}'))]
            if result == 'ack' and receiver in self.sent.get(step, ()) and self.handed.get(step) != receiver:
                fx.append(self._revoke(step, receiver, f'sensor {receiver} took the handoff of step {step} '
                                                       'after it was re-selected: revoking its chain'))
            return fx
        fx: list[Effect] = [Disarm(step, receiver)]
        if result == 'ack':
            self.suspects.discard(receiver)
            self.handed[step] = receiver
            del self.outgoing[step]
            return fx
        self.nacks += 1
        fx.append(Log('warning', f'sensor {receiver} refused the handoff of step {step} ({message}); re-selecting'))
        return fx + self._send_next(out, 'nack')

    def timeout(self, step: int, receiver: int) -> list[Effect]:
        """The ack timer of (``step``, ``receiver``) expired."""
        out = self.outgoing.get(step)
        if out is None or out.receiver != receiver:
            return []
        self.timeouts += 1
        self.suspects.add(out.receiver)
        fx: list[Effect] = [Disarm(step, receiver), Log(
            'warning', f'no ack from sensor {out.receiver} for the handoff of step {out.step} within '
                       f'{self.s.ack_timeout:g} s; re-selecting')]
        return fx + self._send_next(out, 'timeout') + self.advance()

    # -- the state machine -------------------------------------------------------------------------
    def advance(self, close_election: bool = False) -> list[Effect]:
        """Answer the buffered handoffs, apply the start rule once the election is complete (or
        ``close_election``), lead every step whose reading is in."""
        if self.layout is None:
            return []
        fx: list[Effect] = []
        while self.inbox:
            fx += self._receive(*self.inbox.pop(0))
        n = self.layout.n
        if not self.start_checked and (close_election or all(k in self.election for k in range(n))):
            self.start_checked = True
            amps = np.array([self.election.get(k, np.nan) for k in range(n)])
            if elected(self.layout, amps) == self.me:
                fx.append(Log('info', f'sensor {self.me} has the highest amplitude at step 0: leading from a '
                                      + ('uniform belief' if self.s.start == 'uniform' else
                                         "belief holding its neighbours' election readings")))
                if self.pending is None:
                    self.pending = Pending(start_belief(self.layout, self.me, amps, self.s.grid, self.s.tracker,
                                                        self.s.start), 0, None)
        while self.pending is not None and self.pending.step in self.readings:
            pend, self.pending = self.pending, None
            fx += self._lead(pend)
        return fx

    def _receive(self, item: Handoff | Unusable | Revocation, age: float | None = None) -> list[Effect]:
        if isinstance(item, Revocation):
            return self._on_revoke(item.sender, item.receiver, item.step)
        if isinstance(item, Unusable):
            h, why, head = None, item.reason, item.address
        else:
            h, head = item, (item.sender, item.receiver, item.step)
            why = validate_handoff(h, self.s.grid, self.layout.n, receiver=self.me)
        if why is None and age is not None and age > self.s.ack_timeout:
            why = f'expired: received {age:.1f} s after it was sent, beyond the ack timeout ({self.s.ack_timeout:g} s)'
        elif why is None and self.pending is not None:
            why = f'busy: already holding the belief for step {self.pending.step}'
        elif why is None and h.step + 1 <= self.last_led:
            why = f'stale: step {h.step + 1} is not after step {self.last_led}, already led here'
        elif why is None and abs(h.step - self.horizon()) > STEP_WINDOW:
            why = f'window: step {h.step} is more than {STEP_WINDOW} steps from step {self.horizon()}'
        if why is not None:
            self.refused += 1
            who = f'sensor {head[0]}, step {head[2]}' if head else 'an unreadable header'
            fx: list[Effect] = [Log('warning', f'refused handoff from {who}: {why}', ('handoff', f'{why} ({who})'))]
            if head is not None and head[0] < self.layout.n:
                fx.append(Reply(head[0], head[2], why))
            return fx
        self.pending = Pending(h.belief(), h.step + 1, h.sender, h.sender)
        return [Reply(h.sender, h.step, None)]

    def _lead(self, pend: Pending) -> list[Effect]:
        """Table 1 steps 1-5 for step ``pend.step`` (``leader_step``) with its reading (predict-only without:
        ``reading_missed``), then the handoff."""
        s, step, layout = self.s, pend.step, self.layout
        z = self.readings.get(step)
        rng = selection_rng(s.seed, self.me, step) if s.selection == 'random' else None
        res = leader_step(pend.belief, z, self.me, layout, s.tracker, step=step, previous=pend.previous,
                          selection=s.selection, rng=rng)
        self.last_led = step
        self.led.append(step)
        self.parent[step] = pend.parent
        self.sent[step] = []
        for book in (self.parent, self.sent, self.handed):  # the chain rule's memory: STEP_WINDOW steps
            for old in [k for k in book if k < step - STEP_WINDOW]:
                del book[old]
        self.void = {v for v in self.void if v >= step - STEP_WINDOW}
        self.led = [v for v in self.led if v >= step - STEP_WINDOW]
        order = handoff_order(res.candidates, res.scores, layout.neighbours[self.me], pend.previous, self.me,
                              first=res.next_leader, last=self.suspects)
        self.outgoing[step] = out = Outgoing(step, res.belief, order)
        return [Led(step, pend.previous, float('nan') if z is None else z, res, order[0]),
                *self._send_next(out, None)]

    def _send_next(self, out: Outgoing, why: str | None) -> list[Effect]:
        """Hand ``out`` to the next sensor in its order (``why``: reason of a re-selection)."""
        if why is not None:
            out.tried.append(out.receiver)
        k = out.order.pop(0)
        fx: list[Effect] = []
        if k == self.me:
            del self.outgoing[out.step]
            self.handed[out.step] = self.me
            if why is not None:
                fx += [Log('warning', f'no neighbour took the handoff of step {out.step} (tried {out.tried}); '
                                      f'sensor {self.me} leads step {out.step + 1} itself'),
                       SelfLead(out.step, tuple(out.tried))]
            if self.pending is not None:
                fx.append(Log('warning', f'dropping the belief of step {out.step}: already holding the one for '
                                         f'step {self.pending.step}'))
                return fx
            self.pending = Pending(out.belief, out.step + 1, None, self.me)
            return fx
        self.sent.setdefault(out.step, []).append(k)
        h = Handoff.from_belief(out.step, self.me, k, out.belief)
        payload = encode_handoff(h)
        if why is not None:
            fx.append(Reselect(out.step, k, out.receiver, why, len(payload)))
        out.receiver = k
        return [*fx, Send(out.step, k, payload, h)]

    # -- the chain rule (module docstring) ------------------------------------------------------------
    def _revoke(self, step: int, receiver: int, text: str) -> Revoke:
        self.revokes += 1
        return Revoke(step, receiver, encode_revoke(step, self.me, receiver), text)

    def _on_revoke(self, sender: int, receiver: int, step: int) -> list[Effect]:
        """``sender`` says its handoff of ``step`` to this sensor is void."""
        if receiver != self.me or sender >= self.layout.n:
            self.refused += 1
            why = f'revoke of step {step} from sensor {sender} addressed to sensor {receiver}'
            return [Log('warning', f'refused {why}', ('revoke', why))]
        return self._cut(step, sender)

    def _cut(self, step: int, parent: int) -> list[Effect]:
        """End the chain that ``parent``'s handoff of ``step`` started here, if it did."""
        nxt = step + 1
        if self.pending is not None and self.pending.step == nxt and self.pending.parent == parent:
            self.pending = None
            return [Log('warning', f'sensor {parent} revoked its handoff of step {step}: dropping the belief '
                                   f'of step {nxt}'), Void(nxt, parent)]
        if nxt not in self.parent or self.parent[nxt] != parent or nxt in self.void:
            return []  # not from that handoff, or already cut
        self.void.add(nxt)
        self.last_led = max((s for s in self.led if s not in self.void), default=-1)
        fx: list[Effect] = [Log('warning', f'sensor {parent} revoked its handoff of step {step}: my lead of step '
                                           f'{nxt} is void, revoking what I handed on'), Void(nxt, parent)]
        out = self.outgoing.pop(nxt, None)
        if out is not None and out.receiver is not None:
            fx.append(Disarm(nxt, out.receiver))
        self.handed.pop(nxt, None)
        for k in dict.fromkeys(self.sent.get(nxt, ())):
            fx.append(self._revoke(nxt, k, f'revoking the handoff of step {nxt} to sensor {k} (void chain)'))
        return fx + self._cut(nxt, self.me)  # and my own continuation after a self-lead
