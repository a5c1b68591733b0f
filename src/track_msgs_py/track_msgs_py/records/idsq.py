"""IDSQ records: the reply to a handoff (``/idsq/sensor_<j>/ack``), the leader events (``/idsq/leader``)
and the leader's belief cloud (``/idsq/belief``).

The first two travel as one ``DiagnosticStatus`` named ``sensor_<id>`` of the sensor that writes it;
``IdsqBelief`` is a ``PointCloud2``: float32 ``x``, ``y`` (the cell centre, map), ``z`` (0), ``p``
(the cell's posterior mass), one point per cell of the sparse belief. The sensor layout cloud is
``track_msgs_py.convert.layout_to_pointcloud2``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Self

import numpy as np
from diagnostic_msgs.msg import DiagnosticStatus
from sensor_msgs.msg import PointCloud2

from track_msgs_py.convert import points_to_pointcloud2, stamp_to_sec
from track_msgs_py.records import DIAG_OK, DIAG_WARN, RecordError, StatusRecord, read_cloud
from track_msgs_py.topics import FRAME_MAP

LEADER_EVENTS = ('step', 'reselect', 'self', 'void')


@dataclass(frozen=True)
class IdsqAck(StatusRecord):
    """``receiver``'s answer to ``sender``'s handoff of ``step``: ``result`` ``ack``, or ``nack`` with the
    reason in the status message (``refused: <reason>``). Any result but ``ack`` counts as a refusal."""

    KIND = 'idsq ack'

    step: int
    sender: int
    receiver: int
    result: str

    @property
    def accepted(self) -> bool:
        return self.result == 'ack'

    @classmethod
    def reply(cls, step: int, sender: int, receiver: int, refusal: str | None) -> DiagnosticStatus:
        """The status ``receiver`` sends back: level OK + ``ack``, or WARN + ``nack`` and ``refused: <refusal>``."""
        rec = cls(step, sender, receiver, 'ack' if refusal is None else 'nack')
        return rec.to_status(f'sensor_{receiver}', DIAG_OK if refusal is None else DIAG_WARN,
                             'ack' if refusal is None else f'refused: {refusal}')


def _bool_word(b: bool) -> str:
    return str(bool(b))  # 'True' / 'False', as the sensors have always written it


@dataclass(frozen=True)
class IdsqLeaderEvent(StatusRecord):
    """One ``/idsq/leader`` event of sensor ``leader``: ``step`` (it led ``step``; the estimate's fields),
    ``reselect`` (the handoff of ``step`` goes to ``next`` after ``failed`` timed out or refused,
    ``reason``), ``self`` (no neighbour took it, ``tried``; ``leader`` leads step + 1 itself) or ``void``
    (its lead of ``step``, from ``previous``'s handoff, was revoked: a parallel chain ended).
    ``previous`` is -1 for no previous leader; ``handoff_bytes`` is 0 when nothing is sent."""

    KIND = 'idsq leader event'

    event: str
    step: int
    leader: int
    next: int
    previous: int | None = None
    z: float | None = None
    updated: bool | None = field(default=None, metadata={'fmt': _bool_word})
    belief_size: int | None = None
    spread_m2: float | None = None
    candidates: tuple[int, ...] | None = None
    mi_bits: tuple[float, ...] | None = field(default=None, metadata={'fmt': '{:.6g}'.format})
    tried: tuple[int, ...] | None = None
    failed: int | None = None
    reason: str | None = None
    handoff_bytes: int = 0

    def __post_init__(self) -> None:
        if self.event not in LEADER_EVENTS:
            raise ValueError(f'event={self.event!r} is not one of {", ".join(LEADER_EVENTS)}')

    @classmethod
    def from_values(cls, values) -> Self:
        if values.get('updated') in ('True', 'False'):  # the wire word of ``updated`` (see _bool_word)
            values = {**values, 'updated': values['updated'].lower()}
        return super().from_values(values)

    def to_status(self, name: str | None = None, level: int | None = None, message: str | None = None,
                  hardware_id: str = '', extra=None) -> DiagnosticStatus:
        """As the sensor publishes it: named ``sensor_<leader>``, OK for ``step`` and WARN otherwise,
        message ``<event> <step>: sensor <leader> -> sensor <next>``."""
        return super().to_status(
            f'sensor_{self.leader}' if name is None else name,
            (DIAG_OK if self.event == 'step' else DIAG_WARN) if level is None else level,
            f'{self.event} {self.step}: sensor {self.leader} -> sensor {self.next}' if message is None else message,
            hardware_id, extra)


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


__all__ = ['LEADER_EVENTS', 'IdsqAck', 'IdsqBelief', 'IdsqLeaderEvent', 'RecordError']
