"""Typed records of the SLAM topics: ``/slam/mode``, ``/slam/events`` and the ``/slam/scan`` table.

- ``SlamMode``: one ``DiagnosticArray`` per processed scan, one status ``<node>/mode`` (level OK,
  message = the mode) with the mode and the node's counters;
- ``SlamEvent``: one ``DiagnosticArray`` per mode switch, one status ``<node>/mode_switch`` (level
  OK for PF → CEKF, WARN otherwise; message e.g. ``CEKF -> PF``) with the pose after the scan of
  the switch;
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
from diagnostic_msgs.msg import DiagnosticArray
from sensor_msgs.msg import PointCloud2

from track_msgs_py.clouds import cloud_columns, scan_to_pointcloud2
from track_msgs_py.diagnostics import diagnostic_array
from track_msgs_py.records import DIAG_OK, DIAG_WARN, RecordError, StatusRecord, read_cloud
from track_msgs_py.stamps import stamp_to_sec
from track_msgs_py.topics import FRAME_LASER

#: ``SlamEvent.event`` → the status message.
EVENT_TEXT = {'to_pf': 'CEKF -> PF', 'to_cekf': 'PF -> CEKF', 'pf_timeout': 'PF -> CEKF (timeout)'}


def _single_status(cls, msg: DiagnosticArray):
    if len(msg.status) != 1:
        raise RecordError(f'{cls.KIND}: expected one status, got {len(msg.status)}')
    return cls.from_status(msg.status[0])


@dataclass(frozen=True)
class SlamMode(StatusRecord):
    """The filter's mode (``CEKF`` or ``PF``) and counters after one scan (the ``/slam/mode`` values)."""

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

    def to_msg(self, t: float, node_name: str) -> DiagnosticArray:
        return diagnostic_array(t, [self.to_status(f'{node_name}/mode', DIAG_OK, self.mode)])

    @classmethod
    def from_msg(cls, msg: DiagnosticArray) -> Self:
        return _single_status(cls, msg)


@dataclass(frozen=True)
class SlamEvent(StatusRecord):
    """One mode switch (``track_core.slam.Event``) and the pose after the scan on which it happened."""

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

    def to_msg(self, node_name: str) -> DiagnosticArray:
        level = DIAG_OK if self.event == 'to_cekf' else DIAG_WARN
        return diagnostic_array(self.t, [self.to_status(f'{node_name}/mode_switch', level, self.text)])

    @classmethod
    def from_msg(cls, msg: DiagnosticArray) -> Self:
        return _single_status(cls, msg)


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
