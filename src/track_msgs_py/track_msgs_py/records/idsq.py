"""IDSQ records: the reply to a handoff (``/idsq/sensor_<j>/ack``), the leader events (``/idsq/leader``),
the leader's belief cloud (``/idsq/belief``), the sensor layout (``/idsq/layout``) and the handoff bytes
(``/idsq/sensor_<j>/handoff``).

The first two travel as one ``DiagnosticStatus`` named ``sensor_<id>`` of the sensor that writes it;
``IdsqBelief`` is a ``PointCloud2``: float32 ``x``, ``y`` (the cell centre, map), ``z`` (0), ``p``
(the cell's posterior mass), one point per cell of the sparse belief. The other two:

=========================  ==========================================  ===============================================
data                       message type                                fields
=========================  ==========================================  ===============================================
IDSQ sensor layout         sensor_msgs/PointCloud2 (``/idsq/layout``)  ``FLOAT32`` ``x``, ``y``, ``z`` (0) at 0, 4,
(``SensorLayout``)                                                     8, 4 bytes padding, ``FLOAT64`` ``id``,
                                                                       ``x_f64``, ``y_f64``, ``type`` (0 acoustic, 1
                                                                       DOA) at 16, 24, 32, 40; ``point_step`` 48; one
                                                                       point per sensor (float64: positions exact)
IDSQ handoff bytes         std_msgs/UInt8MultiArray                    ``data`` = the bytes; one ``layout.dim``:
(``encode_handoff``)                                                   label ``idsq_handoff_v1``, size = stride = n
=========================  ==========================================  ===============================================

The layout carries its positions twice: float32 ``x``, ``y`` for the viewers and float64 ``x_f64``,
``y_f64`` that every sensor node reads: it checks its ``position`` parameter against them and builds
its neighbour lists from them, so all must read the same exact positions. A layout without
``x_f64``/``y_f64`` (float64 ``id``, ``x``, ``y``, ``type`` only) reads its positions from ``x``, ``y``.
``pointcloud2_to_layout`` imports ``track_core.idsq`` only when called (it loads scipy.stats, about
1 s, which the other users of this module need not pay).
"""

from __future__ import annotations

import array
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Self

import numpy as np
from diagnostic_msgs.msg import DiagnosticStatus
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import MultiArrayDimension, UInt8MultiArray

from track_msgs_py.clouds import XYZ, pack_cloud, pointcloud2_to_table, points_to_pointcloud2
from track_msgs_py.records import DIAG_OK, DIAG_WARN, RecordError, StatusRecord, read_cloud
from track_msgs_py.stamps import stamp_to_sec
from track_msgs_py.topics import FRAME_MAP

if TYPE_CHECKING:
    from track_core.idsq.network import SensorLayout

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


# --- the sensor layout ⇄ PointCloud2, handoff bytes ⇄ UInt8MultiArray ------------------------

#: The FLOAT64 fields of the ``/idsq/layout`` cloud, after float32 x, y, z (type 0 acoustic, 1 DOA).
LAYOUT_FIELDS = ('id', 'x_f64', 'y_f64', 'type')
_LAYOUT_DTYPE = np.dtype({'names': [*XYZ, *LAYOUT_FIELDS], 'formats': ['<f4'] * 3 + ['<f8'] * 4,
                          'offsets': [0, 4, 8, 16, 24, 32, 40], 'itemsize': 48})
#: ``layout.dim[0].label`` of a handoff message: ``data`` is ``track_core.idsq.encode_handoff`` bytes.
HANDOFF_LABEL = 'idsq_handoff_v1'


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


def handoff_to_uint8_array(payload: bytes) -> UInt8MultiArray:
    """Handoff bytes (``encode_handoff``) → ``std_msgs/UInt8MultiArray`` labelled ``HANDOFF_LABEL``."""
    msg = UInt8MultiArray()
    msg.layout.dim = [MultiArrayDimension(label=HANDOFF_LABEL, size=len(payload), stride=len(payload))]
    msg.data = array.array('B', payload)
    return msg


def uint8_array_to_handoff(msg: UInt8MultiArray) -> bytes:
    """``std_msgs/UInt8MultiArray`` → its ``data`` as bytes, unchecked (``receive_handoff`` validates)."""
    return msg.data.tobytes() if hasattr(msg.data, 'tobytes') else bytes(msg.data)


__all__ = ['HANDOFF_LABEL', 'LAYOUT_FIELDS', 'LEADER_EVENTS', 'IdsqAck', 'IdsqBelief', 'IdsqLeaderEvent', 'RecordError',
           'handoff_to_uint8_array', 'layout_to_pointcloud2', 'pointcloud2_to_layout', 'uint8_array_to_handoff']
