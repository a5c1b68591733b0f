"""Typed records of the SLAM topics: ``/slam/mode``, ``/slam/events`` and the ``/slam/scan`` table.

- ``SlamMode``: one ``track_msgs/SlamStatus`` per processed scan: the mode and the node's counters;
- ``SlamEvent``: one ``track_msgs/SlamEvent`` per mode switch, with the pose after the scan of the
  switch;
- ``SlamScan``: one laser scan as a ``PointCloud2`` table: float32 ``x``, ``y``, ``z`` (the detection
  in the laser frame, x ahead and y left: ``clouds.scan_points``, z = 0; for the viewers, never
  read back), then float32 ``range``, ``bearing``, ``diameter`` and any extra column such as
  slam_sim's ``landmark``; built by ``clouds.scan_to_pointcloud2`` and read by
  ``clouds.pointcloud2_to_table``.

The ``slam`` node writes them, ``slam_sim`` writes scans, and the summary and the tests read them.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Self

import numpy as np
from sensor_msgs.msg import PointCloud2

from track_msgs import msg as tm
from track_msgs_py.clouds import cloud_columns, scan_to_pointcloud2
from track_msgs_py.records import RecordError, read_cloud
from track_msgs_py.stamps import stamp_to_sec, stamped_header
from track_msgs_py.topics import FRAME_LASER, FRAME_MAP

#: ``SlamEvent.event`` → the status message.
EVENT_TEXT = {'to_pf': 'CEKF -> PF', 'to_cekf': 'PF -> CEKF', 'pf_timeout': 'PF -> CEKF (timeout)'}


MODES = ('CEKF', 'PF')  # SlamStatus.mode 0, 1
EVENTS = ('to_pf', 'to_cekf', 'pf_timeout')  # SlamEvent.event 0, 1, 2 (``track_core.slam.Event.kind``)


def _code(kind: str, names: tuple[str, ...], value: str) -> int:
    if value not in names:
        raise RecordError(f'{kind}: {value!r} is not one of {names}')
    return names.index(value)


def _name(kind: str, names: tuple[str, ...], code: int) -> str:
    if not 0 <= code < len(names):
        raise RecordError(f'{kind}: code {code} is not one of 0..{len(names) - 1} ({", ".join(names)})')
    return names[code]


@dataclass(frozen=True)
class SlamMode:
    """The filter's mode (``CEKF`` or ``PF``) and counters after one scan (``/slam/mode``, ``SlamStatus``)."""

    KIND = 'slam mode'

    mode: str
    scans: int
    inputs: int
    landmarks: int
    pf_switches: int
    pf_scans: int  # scans of the current PF episode (0 in CEKF)
    dropped_observations: int
    refused_messages: int
    bad_inputs: int
    bad_scans: int

    def to_msg(self, t: float) -> tm.SlamStatus:
        return tm.SlamStatus(header=stamped_header(t, ''), mode=_code(self.KIND, MODES, self.mode), scans=self.scans,
                             inputs=self.inputs, landmarks=self.landmarks, pf_switches=self.pf_switches,
                             pf_scans=self.pf_scans, dropped_observations=self.dropped_observations,
                             refused_messages=self.refused_messages, bad_inputs=self.bad_inputs,
                             bad_scans=self.bad_scans)

    @classmethod
    def from_msg(cls, msg: tm.SlamStatus) -> Self:
        return cls(_name(cls.KIND, MODES, msg.mode), msg.scans, msg.inputs, msg.landmarks, msg.pf_switches,
                   msg.pf_scans, msg.dropped_observations, msg.refused_messages, msg.bad_inputs, msg.bad_scans)


@dataclass(frozen=True)
class SlamEvent:
    """One mode switch (``track_core.slam.Event``) and the pose after the scan on which it happened
    (``/slam/events``, ``track_msgs/SlamEvent``)."""

    KIND = 'slam event'

    event: str  # to_pf, to_cekf or pf_timeout
    t: float
    pf_scans: int  # PF scans of the episode that ended (0 for to_pf)
    x: float
    y: float
    yaw: float

    @property
    def text(self) -> str:
        return EVENT_TEXT.get(self.event, self.event)

    def to_msg(self, frame_id: str = FRAME_MAP) -> tm.SlamEvent:
        return tm.SlamEvent(header=stamped_header(self.t, frame_id), event=_code(self.KIND, EVENTS, self.event),
                            pf_scans=self.pf_scans, x=float(self.x), y=float(self.y), yaw=float(self.yaw))

    @classmethod
    def from_msg(cls, msg: tm.SlamEvent) -> Self:
        return cls(_name(cls.KIND, EVENTS, msg.event), stamp_to_sec(msg.header.stamp), msg.pf_scans, msg.x, msg.y,
                   msg.yaw)


@dataclass(frozen=True, eq=False)
class SlamScan:
    """One scan: per tree, ``range`` [m, to the trunk surface], ``bearing`` [rad, eq. 5: 0 = right,
    π/2 ahead], ``diameter`` [m, 0 for point landmarks]; ``extra``: further columns (evaluation).
    The message's x, y, z are derived from range and bearing, so they are not part of the record."""

    t: float
    range: np.ndarray
    bearing: np.ndarray
    diameter: np.ndarray
    extra: Mapping[str, np.ndarray] = field(default_factory=dict)
    frame_id: str = FRAME_LASER

    @property
    def z(self) -> np.ndarray:
        """(n, 2) of (range, bearing)."""
        return np.stack([self.range, self.bearing], axis=1)

    def to_msg(self) -> PointCloud2:
        return scan_to_pointcloud2(self.t, self.z, self.diameter, self.frame_id, **self.extra)

    @classmethod
    def from_msg(cls, msg: PointCloud2) -> Self:
        """Needs 1-D fields ``range`` and ``bearing``; a missing ``diameter`` reads as 0, missing x, y, z (a scan
        recorded by earlier versions) are fine. Else ``RecordError``."""
        table = cloud_columns(read_cloud('slam scan', msg, ('range', 'bearing')))
        r = table.pop('range')
        b = table.pop('bearing')
        d = table.pop('diameter', np.zeros_like(r))
        if d.ndim != 1:
            raise RecordError('slam scan: diameter must have count 1')
        return cls(stamp_to_sec(msg.header.stamp), r, b, d, table, msg.header.frame_id)
