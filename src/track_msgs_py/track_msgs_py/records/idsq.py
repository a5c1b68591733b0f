"""IDSQ records: a sensor's reading (``track_msgs/IdsqReading``), the protocol messages (``track_msgs``
``IdsqHandoff``, ``IdsqAck``, ``IdsqRevoke``, ``IdsqLeaderEvent``), the leader's belief cloud
(``/idsq/belief``) and the sensor layout (``/idsq/layout``).

One record per layout, each with ``to_msg``/``from_msg``; ``from_msg`` raises ``RecordError`` with
one line, which a node passes to its ``refuse``. Topics are in ``topics.py``.

- ``IdsqReading`` (``/idsq/sensor_<id>/reading``, ``/idsq/election``): ``amplitude`` as is (eq. 5's
  z); ``direction`` REP-103 in ``map`` (``header.frame_id`` must be ``map``), read by ``bearing`` as
  the paper's θ = wrap(π/2 − direction) (clockwise from north, eq. 11); ``t`` = the step's stamp.
- ``IdsqHandoff`` (``/idsq/sensor_<receiver>/handoff``): field for field
  ``track_core.idsq.handoff.Package`` (u32 cells, f32 mass: the belief to the bit).
- ``IdsqAck`` (``/idsq/sensor_<sender>/ack``): ``accepted`` false is a nack, ``reason`` at most
  ``MAX_REASON`` characters. ``IdsqRevoke`` (``/idsq/sensor_<receiver>/revoke``): the handoff of
  ``step`` from ``sender`` is void; nothing orders it against the handoffs.
- ``IdsqLeaderEvent`` (``/idsq/leader``): ``event`` as a word (``LEADER_EVENTS``); a field the event
  does not carry (``EVENT_FIELDS``) is ``None`` here, 0 / -1 / NaN / empty on the wire.
- ``received_handoff``: the ``Handoff``, or an ``Unusable`` with the reason and the address.
- ``IdsqBelief``: PointCloud2, float32 ``x``, ``y`` (cell centre, map), ``z`` (0), ``p`` (mass).
- ``SensorLayout``: PointCloud2, ``FLOAT32`` ``x``, ``y``, ``z`` at 0, 4, 8, ``FLOAT64`` ``id``,
  ``x_f64``, ``y_f64``, ``type`` (0 acoustic, 1 DOA) at 16, 24, 32, 40; ``point_step`` 48; every
  sensor reads the exact float64 positions (a layout without them: from ``x``, ``y``). The
  conversions to core types import ``track_core.idsq`` only when called (scipy.stats, ~1 s).
"""

from __future__ import annotations

import array
import dataclasses
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Self

import numpy as np
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import Header

from track_msgs.msg import IdsqAck as IdsqAckMsg
from track_msgs.msg import IdsqHandoff as IdsqHandoffMsg
from track_msgs.msg import IdsqLeaderEvent as IdsqLeaderEventMsg
from track_msgs.msg import IdsqReading as IdsqReadingMsg
from track_msgs.msg import IdsqRevoke as IdsqRevokeMsg
from track_msgs_py.clouds import XYZ, pack_cloud, pointcloud2_to_table, points_to_pointcloud2
from track_msgs_py.records import RecordError, read_cloud
from track_msgs_py.stamps import sec_to_stamp, stamp_to_sec
from track_msgs_py.topics import FRAME_MAP, idsq_ack_topic, idsq_handoff_topic, idsq_reading_topic, idsq_revoke_topic

if TYPE_CHECKING:
    from track_core.idsq.handoff import Handoff, Package, Unusable
    from track_core.idsq.network import SensorLayout
    from track_core.idsq.readings import Reading

MAX_REASON = 1000  # characters of a nack's reason (it goes into one log line of the sender)
#: The per-sensor topics: kind → (message type, topic of sensor k) (the protocol's three, and the readings).
PROTOCOL = {'handoff': (IdsqHandoffMsg, idsq_handoff_topic), 'ack': (IdsqAckMsg, idsq_ack_topic),
            'revoke': (IdsqRevokeMsg, idsq_revoke_topic), 'reading': (IdsqReadingMsg, idsq_reading_topic)}


def _header(t: float, frame_id: str = '') -> Header:
    """Stamped ``t`` [s], or 0 when a stamp cannot hold it (the time of an absurd step number)."""
    return Header(stamp=sec_to_stamp(t if 0.0 < t < 2**31 - 1 else 0.0), frame_id=frame_id)


def _u32(values) -> array.array:
    return array.array('I', np.asarray(values, dtype=np.uint32).tobytes())


def _u16(values) -> array.array:
    return array.array('H', [int(v) for v in values or ()])


def _one_line(kind: str, name: str, text: str) -> None:
    if len(text) > MAX_REASON or not text.isprintable():
        raise RecordError(f'{kind}: {name} must be one printable line of at most {MAX_REASON} characters '
                          f'(got {len(text)})')


# --- the reading --------------------------------------------------------------------------------

READING_TYPES = {IdsqReadingMsg.ACOUSTIC: False, IdsqReadingMsg.DOA: True}  # type code → is DOA


@dataclass(frozen=True)
class IdsqReading:
    """One sensor's reading of one step at time ``t`` [s], as ``track_msgs/IdsqReading`` carries it:
    ``amplitude`` (NaN if none; an acoustic sensor's measurement, eq. 5), and for a DOA sensor the
    REP-103 ``direction`` [rad] in ``frame_id`` and its ``direction_std`` [rad] (NaN here for an acoustic one;
    0 on the wire, which carries no NaN the sensor did not give).

    The tracker's DOA likelihood uses the Fig. 6 σ(r) of its own parameters (``sigma_doa_deg``,
    ``r_near``, ``r_far``): ``direction_std`` is what the front end claims, carried for the record
    and checked (finite, > 0), not a weight."""

    KIND = 'idsq reading'

    t: float
    sensor: int
    is_doa: bool
    amplitude: float
    direction: float = math.nan
    direction_std: float = math.nan
    frame_id: str = FRAME_MAP

    @classmethod
    def of_reading(cls, t: float, r: Reading, frame_id: str = FRAME_MAP) -> Self:
        """The message of the core's reading ``r`` (its bearing θ turned into a REP-103 direction)."""
        from track_core.idsq.readings import direction_of_bearing

        if not r.is_doa:
            return cls(t, r.sensor, False, r.amplitude, frame_id=frame_id)
        return cls(t, r.sensor, True, r.amplitude, direction_of_bearing(r.bearing), r.bearing_std, frame_id)

    @property
    def bearing(self) -> float:
        """The paper's θ (eq. 11: clockwise from north) of the direction; NaN for an acoustic reading."""
        from track_core.idsq.readings import bearing_of_direction

        return bearing_of_direction(self.direction) if self.is_doa else math.nan

    @property
    def z(self) -> float:
        """What the sensor leads with: θ for a DOA reading (eq. 11), the amplitude otherwise (eq. 6)."""
        return self.bearing if self.is_doa else self.amplitude

    def problem(self, sensor: int, is_doa: bool) -> str | None:
        """Why sensor ``sensor`` (DOA or not) cannot use this reading (another sensor's, another type), else None."""
        if self.sensor != sensor:
            return f'sensor_id: {self.sensor} is not this sensor ({sensor})'
        if self.is_doa != is_doa:
            return (f'type: {"DOA" if self.is_doa else "ACOUSTIC"} reading for '
                    f'{"a DOA" if is_doa else "an acoustic"} sensor')
        return None

    def to_msg(self) -> IdsqReadingMsg:
        return IdsqReadingMsg(header=_header(self.t, self.frame_id), sensor_id=int(self.sensor),
                              type=IdsqReadingMsg.DOA if self.is_doa else IdsqReadingMsg.ACOUSTIC,
                              amplitude=float(self.amplitude),
                              direction=float(self.direction) if self.is_doa else 0.0,
                              direction_std=float(self.direction_std) if self.is_doa else 0.0)

    @classmethod
    def from_msg(cls, msg: IdsqReadingMsg, frame_id: str = FRAME_MAP) -> Self:
        """``RecordError`` (one line) for an unknown type, an acoustic reading without a finite amplitude, a
        DOA one without a finite direction and a finite positive std, an infinite amplitude, or a DOA
        direction in another frame than ``frame_id`` (rotate it into map first; an empty one is map)."""
        if msg.type not in READING_TYPES:
            raise RecordError(f'{cls.KIND}: type={msg.type} is neither ACOUSTIC (0) nor DOA (1)')
        doa = READING_TYPES[msg.type]
        amp, d, sd = float(msg.amplitude), float(msg.direction), float(msg.direction_std)
        if math.isinf(amp) or (not doa and math.isnan(amp)):
            raise RecordError(f'{cls.KIND}: amplitude={amp} must be finite' + ('' if doa else ' (an acoustic reading)'))
        frame = msg.header.frame_id or frame_id
        if doa:
            if not math.isfinite(d):
                raise RecordError(f'{cls.KIND}: direction={d} must be finite (a DOA reading)')
            if not (math.isfinite(sd) and sd > 0.0):
                raise RecordError(f'{cls.KIND}: direction_std={sd} must be finite and > 0 (a DOA reading)')
            if frame != frame_id:
                raise RecordError(f'{cls.KIND}: header.frame_id={frame!r}: the direction must be in {frame_id!r}')
            return cls(stamp_to_sec(msg.header.stamp), int(msg.sensor_id), True, amp, d, sd, frame)
        return cls(stamp_to_sec(msg.header.stamp), int(msg.sensor_id), False, amp, frame_id=frame)


# --- the handoff --------------------------------------------------------------------------------

@dataclass(frozen=True, eq=False)
class IdsqHandoff:
    """The handoff package of Table 1 step 5 as ``track_msgs/IdsqHandoff`` carries it (fields of
    ``track_core.idsq.handoff.Package``; ``cells`` uint32, ``mass`` float32) at time ``t`` [s]."""

    KIND = 'idsq handoff'

    t: float
    version: int
    step: int
    sender: int
    receiver: int
    x0: float
    y0: float
    cell: float
    nx: int
    ny: int
    cells: np.ndarray
    mass: np.ndarray
    velocity: tuple[float, float] = (0.0, 0.0)
    observations: int = 0
    bank_spacing: float = 0.0
    hypotheses: int = 0
    frame_id: str = FRAME_MAP

    @classmethod
    def of_package(cls, t: float, p: Package, frame_id: str = FRAME_MAP) -> Self:
        return cls(t, **{f.name: getattr(p, f.name) for f in dataclasses.fields(p)}, frame_id=frame_id)

    @classmethod
    def from_handoff(cls, t: float, h: Handoff, frame_id: str = FRAME_MAP) -> Self:
        """``h`` rounded as it travels (``track_core.idsq.handoff.to_package``)."""
        from track_core.idsq.handoff import to_package

        return cls.of_package(t, to_package(h), frame_id)

    def package(self) -> Package:
        from track_core.idsq.handoff import Package

        return Package(**{f.name: getattr(self, f.name) for f in dataclasses.fields(Package)})

    def to_handoff(self) -> Handoff:
        """The carried ``Handoff``; ``ValueError`` with one line if the package is unreadable
        (``from_package``: unknown version, arrays of different lengths, ...)."""
        from track_core.idsq.handoff import from_package

        return from_package(self.package())

    @property
    def package_bytes(self) -> int:
        """Size of the package [bytes] (``payload_bytes``): the communication cost we report."""
        from track_core.idsq.handoff import VERSION_BANK, VERSION_MOTION, payload_bytes

        return payload_bytes(len(self.cells), self.version == VERSION_MOTION, self.version == VERSION_BANK)

    def to_msg(self) -> IdsqHandoffMsg:
        return IdsqHandoffMsg(
            header=_header(self.t, self.frame_id), version=int(self.version), step=int(self.step),
            sender=int(self.sender), receiver=int(self.receiver), grid_x0=float(self.x0), grid_y0=float(self.y0),
            grid_cell=float(self.cell), grid_nx=int(self.nx), grid_ny=int(self.ny), cells=_u32(self.cells),
            mass=array.array('f', np.asarray(self.mass, dtype=np.float32).tobytes()),
            velocity_x=float(self.velocity[0]), velocity_y=float(self.velocity[1]),
            observations=int(self.observations), bank_spacing=float(self.bank_spacing),
            bank_hypotheses=int(self.hypotheses))

    @classmethod
    def from_msg(cls, msg: IdsqHandoffMsg, frame_id: str | None = FRAME_MAP) -> Self:
        """The fields as they came; ``RecordError`` if the grid is not in ``frame_id`` (``None``: any frame).
        The other checks are ``to_handoff``'s, one place for both wire forms."""
        if frame_id is not None and msg.header.frame_id != frame_id:
            raise RecordError(f'{cls.KIND}: header.frame_id={msg.header.frame_id!r}, the grid is in {frame_id!r}')
        return cls(stamp_to_sec(msg.header.stamp), msg.version, msg.step, msg.sender, msg.receiver, msg.grid_x0,
                   msg.grid_y0, msg.grid_cell, msg.grid_nx, msg.grid_ny, np.frombuffer(msg.cells, dtype=np.uint32),
                   np.frombuffer(msg.mass, dtype=np.float32), (msg.velocity_x, msg.velocity_y), msg.observations,
                   msg.bank_spacing, msg.bank_hypotheses, msg.header.frame_id)


def received_handoff(msg: IdsqHandoffMsg, frame_id: str = FRAME_MAP) -> Handoff | Unusable:
    """What a sensor's ledger takes from a handoff message (``HandoffLedger.on_handoff``): the
    ``Handoff``, or ``Unusable`` with the one-line reason and the address, which a typed message
    always has (so the refusal is answered)."""
    from track_core.idsq.handoff import Unusable

    try:
        return IdsqHandoff.from_msg(msg, frame_id).to_handoff()
    except ValueError as exc:  # RecordError included
        return Unusable(str(exc), (msg.sender, msg.receiver, msg.step))


# --- the ack and the revoke -----------------------------------------------------------------------

@dataclass(frozen=True)
class IdsqAck:
    """``receiver``'s answer to ``sender``'s handoff of ``step`` at time ``t`` [s]: an ack, or a nack
    (``accepted`` false) with the ``reason``."""

    KIND = 'idsq ack'

    step: int
    sender: int
    receiver: int
    accepted: bool
    reason: str = ''
    t: float = 0.0

    @property
    def result(self) -> str:
        """``ack`` or ``nack``, the words of ``HandoffLedger.on_reply``."""
        return 'ack' if self.accepted else 'nack'

    @classmethod
    def reply(cls, step: int, sender: int, receiver: int, refusal: str | None, t: float = 0.0) -> Self:
        """The answer ``receiver`` sends back: an ack (``refusal`` None) or a nack with ``refusal``."""
        return cls(step, sender, receiver, refusal is None, refusal or '', t)

    def to_msg(self) -> IdsqAckMsg:
        return IdsqAckMsg(header=_header(self.t), step=int(self.step), sender=int(self.sender),
                          receiver=int(self.receiver), accepted=bool(self.accepted), reason=self.reason)

    @classmethod
    def from_msg(cls, msg: IdsqAckMsg) -> Self:
        """``RecordError`` for a reason that is not one printable line of at most ``MAX_REASON`` characters."""
        _one_line(cls.KIND, 'reason', msg.reason)
        return cls(msg.step, msg.sender, msg.receiver, msg.accepted, msg.reason, stamp_to_sec(msg.header.stamp))


@dataclass(frozen=True)
class IdsqRevoke:
    """``sender`` revokes its handoff of ``step`` to ``receiver`` (the chain rule), sent at ``t`` [s]."""

    step: int
    sender: int
    receiver: int
    t: float = 0.0

    def to_msg(self) -> IdsqRevokeMsg:
        return IdsqRevokeMsg(header=_header(self.t), step=int(self.step), sender=int(self.sender),
                             receiver=int(self.receiver))

    @classmethod
    def from_msg(cls, msg: IdsqRevokeMsg) -> Self:
        return cls(msg.step, msg.sender, msg.receiver, stamp_to_sec(msg.header.stamp))


# --- the leader events ------------------------------------------------------------------------------

LEADER_EVENTS = ('step', 'reselect', 'self', 'void')
EVENT_CODES = {'step': IdsqLeaderEventMsg.STEP, 'reselect': IdsqLeaderEventMsg.RESELECT,
               'self': IdsqLeaderEventMsg.SELF, 'void': IdsqLeaderEventMsg.VOID}
#: The optional fields each event carries (``handoff_bytes`` and the address: every event).
EVENT_FIELDS = {'step': ('previous', 'z', 'updated', 'belief_size', 'spread_m2', 'candidates', 'mi_bits'),
                'reselect': ('failed', 'reason'), 'self': ('tried',), 'void': ('previous',)}
_OPTIONAL = ('previous', 'z', 'updated', 'belief_size', 'spread_m2', 'candidates', 'mi_bits', 'tried', 'failed',
             'reason')


@dataclass(frozen=True)
class IdsqLeaderEvent:
    """One ``/idsq/leader`` event of sensor ``leader`` at time ``t`` [s]: ``step`` (it led ``step``; the
    estimate's fields), ``reselect`` (the handoff of ``step`` goes to ``next`` after ``failed`` timed out
    or refused, ``reason``), ``self`` (no neighbour took it, ``tried``; ``leader`` leads step + 1 itself)
    or ``void`` (its lead of ``step``, from ``previous``'s handoff, was revoked: a parallel chain ended).
    ``previous`` is -1 for no previous leader; ``handoff_bytes`` is 0 when nothing is sent. A field its
    event does not carry (``EVENT_FIELDS``) must be ``None``."""

    KIND = 'idsq leader event'

    event: str
    step: int
    leader: int
    next: int
    previous: int | None = None
    z: float | None = None
    updated: bool | None = None
    belief_size: int | None = None
    spread_m2: float | None = None
    candidates: tuple[int, ...] | None = None
    mi_bits: tuple[float, ...] | None = None
    tried: tuple[int, ...] | None = None
    failed: int | None = None
    reason: str | None = None
    handoff_bytes: int = 0
    t: float = 0.0

    def __post_init__(self) -> None:
        if self.event not in LEADER_EVENTS:
            raise ValueError(f'event={self.event!r} is not one of {", ".join(LEADER_EVENTS)}')
        extra = [k for k in _OPTIONAL if k not in EVENT_FIELDS[self.event] and getattr(self, k) is not None]
        if extra:
            raise ValueError(f'a {self.event} event does not carry {", ".join(extra)}')

    def to_msg(self) -> IdsqLeaderEventMsg:
        def num(v, none):
            return none if v is None else v

        return IdsqLeaderEventMsg(
            header=_header(self.t), event=EVENT_CODES[self.event], step=int(self.step), leader=int(self.leader),
            next=int(self.next), previous=int(num(self.previous, -1)), z=float(num(self.z, math.nan)),
            updated=bool(self.updated), belief_size=int(num(self.belief_size, 0)),
            spread_m2=float(num(self.spread_m2, math.nan)), candidates=_u16(self.candidates),
            mi_bits=array.array('d', [float(v) for v in self.mi_bits or ()]), tried=_u16(self.tried),
            failed=int(num(self.failed, -1)), reason=self.reason or '', handoff_bytes=int(self.handoff_bytes))

    @classmethod
    def from_msg(cls, msg: IdsqLeaderEventMsg) -> Self:
        """``RecordError`` for an unknown event code or candidates and scores of different lengths."""
        event = next((k for k, code in EVENT_CODES.items() if code == msg.event), None)
        if event is None:
            raise RecordError(f'{cls.KIND}: event code {msg.event} is not one of '
                              + ', '.join(f'{c} ({k})' for k, c in EVENT_CODES.items()))
        if len(msg.candidates) != len(msg.mi_bits):
            raise RecordError(f'{cls.KIND}: {len(msg.candidates)} candidates but {len(msg.mi_bits)} scores')
        have = {'previous': msg.previous, 'z': msg.z, 'updated': msg.updated, 'belief_size': msg.belief_size,
                'spread_m2': msg.spread_m2, 'candidates': tuple(msg.candidates), 'mi_bits': tuple(msg.mi_bits),
                'tried': tuple(msg.tried), 'failed': msg.failed, 'reason': msg.reason}
        return cls(event, msg.step, msg.leader, msg.next, **{k: have[k] for k in EVENT_FIELDS[event]},
                   handoff_bytes=msg.handoff_bytes, t=stamp_to_sec(msg.header.stamp))


def leader_event(fx, me: int) -> IdsqLeaderEvent:
    """The ``/idsq/leader`` event of sensor ``me``'s ledger effect ``fx`` (``track_core.idsq.leader_protocol``
    ``Led``, ``Reselect``, ``SelfLead`` or ``Void``)."""
    from track_core.idsq import leader_protocol as lp

    if isinstance(fx, lp.Led):
        res, est = fx.result, fx.result.estimate
        return IdsqLeaderEvent(
            'step', fx.step, me, fx.next, previous=-1 if fx.previous is None else fx.previous, z=fx.z,
            updated=bool(res.updated), belief_size=int(est.size), spread_m2=float(est.spread),
            candidates=tuple(int(c) for c in res.candidates), mi_bits=tuple(float(s) for s in res.scores),
            handoff_bytes=len(res.payload) if fx.next != me else 0)
    if isinstance(fx, lp.Reselect):
        return IdsqLeaderEvent('reselect', fx.step, me, fx.receiver, failed=fx.failed, reason=fx.reason,
                               handoff_bytes=fx.handoff_bytes)
    if isinstance(fx, lp.SelfLead):
        return IdsqLeaderEvent('self', fx.step, me, me, tried=tuple(fx.tried))
    if isinstance(fx, lp.Void):
        return IdsqLeaderEvent('void', fx.step, me, me, previous=-1 if fx.parent is None else fx.parent)
    raise TypeError(f'{type(fx).__name__} is no leader event')


# --- the belief cloud ---------------------------------------------------------------------------

@dataclass(frozen=True, eq=False)
class IdsqBelief:
    """The sparse grid belief of step ``t``'s leader: cell centres ``xy`` (n, 2) [m, map] and masses ``p`` (n,)."""

    t: float
    xy: np.ndarray
    p: np.ndarray
    frame_id: str = FRAME_MAP

    def to_msg(self) -> PointCloud2:
        return points_to_pointcloud2(self.t, self.frame_id, self.xy, {'p': self.p})

    @classmethod
    def from_msg(cls, msg: PointCloud2) -> Self:
        table = read_cloud('idsq belief', msg, ('x', 'y', 'p'))
        return cls(stamp_to_sec(msg.header.stamp), np.stack([table['x'], table['y']], axis=1), table['p'],
                   msg.header.frame_id)


# --- the sensor layout ⇄ PointCloud2 ----------------------------------------------------------------

#: The FLOAT64 fields of the ``/idsq/layout`` cloud, after float32 x, y, z (type 0 acoustic, 1 DOA).
LAYOUT_FIELDS = ('id', 'x_f64', 'y_f64', 'type')
_LAYOUT_DTYPE = np.dtype({'names': [*XYZ, *LAYOUT_FIELDS], 'formats': ['<f4'] * 3 + ['<f8'] * 4,
                          'offsets': [0, 4, 8, 16, 24, 32, 40], 'itemsize': 48})


def layout_to_pointcloud2(t: float, layout: SensorLayout, frame_id: str = FRAME_MAP) -> PointCloud2:
    """IDSQ sensor layout → ``PointCloud2``, one point per sensor: float32 x, y, z (0) for the viewers,
    then FLOAT64 ``LAYOUT_FIELDS`` (the positions again, exactly, for every node; see the module table)."""
    pos = layout.positions
    return pack_cloud(t, frame_id, {'x': pos[:, 0], 'y': pos[:, 1], 'z': np.zeros(layout.n),
                                    'id': np.arange(layout.n), 'x_f64': pos[:, 0], 'y_f64': pos[:, 1],
                                    'type': layout.is_doa.astype(float)}, _LAYOUT_DTYPE)


def pointcloud2_to_layout(msg: PointCloud2, comm_range: float) -> SensorLayout:
    """Inverse of ``layout_to_pointcloud2`` (points in any order); ``ValueError`` with a one-line reason
    if unusable. ``comm_range`` [m] is the receiver's neighbour rule (not carried by the message)."""
    from track_core.idsq.network import SensorLayout  # here, not at the top: track_core.idsq loads scipy.stats

    cols = pointcloud2_to_table(msg)
    if 'x_f64' not in cols and 'y_f64' not in cols and 'x' in cols and 'y' in cols:  # no float64 positions
        cols['x_f64'], cols['y_f64'] = cols['x'], cols['y']
    missing = [f for f in LAYOUT_FIELDS if f not in cols]
    if missing:
        raise ValueError(f'layout has no field(s) {", ".join(missing)}')
    ids = cols['id']
    order = np.argsort(ids, kind='stable')
    if not np.array_equal(ids[order], np.arange(ids.size)):
        raise ValueError(f'layout ids must be 0..{ids.size - 1} once each')
    types = cols['type'][order]
    if not np.all((types == 0) | (types == 1)):
        raise ValueError('layout type must be 0 (acoustic) or 1 (DOA)')
    pos = np.stack([cols['x_f64'][order], cols['y_f64'][order]], axis=1)
    return SensorLayout(pos, types == 1, comm_range)


__all__ = ['EVENT_CODES', 'EVENT_FIELDS', 'LAYOUT_FIELDS', 'LEADER_EVENTS', 'MAX_REASON', 'PROTOCOL', 'IdsqAck',
           'IdsqBelief', 'IdsqHandoff', 'IdsqLeaderEvent', 'IdsqRevoke', 'RecordError', 'layout_to_pointcloud2',
           'leader_event', 'pointcloud2_to_layout', 'received_handoff']
