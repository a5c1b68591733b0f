"""A reader carried by a robot: each MOVE's motion from the robot's odometry, not from the instruction.

The robot's driver publishes its pose over time (REP-105: base_link in odom). The reader sits at
``reader_pose`` (x, y, yaw) in base_link. A MOVE result covers the interval [t0, t1] of its reads
(the step result's stamp minus its duration, and its stamp); the filter's motion for it
(``pf.MeasuredMotion``, eqs. 19–20) is the reader's pose at t0 seen from its pose at the end of the
previous MOVE the filter took (the turns and any shift since), and its pose at t1 seen from t0.
The odom poses at t0 and t1 are interpolated between the recorded ones by ``filters.poses.OdomTrack``.
A step is covered when odometry has come from before t0 to at or after t1; the caller waits for that
(``covers``), and after its wait refuses the step with ``gap``'s reason.
"""

from __future__ import annotations

import numpy as np

from track_core.filters.poses import OdomTrack, compose
from track_core.rfid.pf import MeasuredMotion

HISTORY_S = 600.0  # odom poses kept [s]: a MOVE's reads are never that long ago when its result comes


class ReaderOdometry:
    """The odom poses of base_link over time, and the reader's measured motion of each MOVE."""

    def __init__(self, reader_pose=(0.0, 0.0, 0.0), history: float = HISTORY_S) -> None:
        mount = np.asarray(reader_pose, dtype=float)
        if mount.shape != (3,) or not np.all(np.isfinite(mount)):
            raise ValueError(f'reader_pose must be 3 finite numbers (x, y, yaw), got {reader_pose!r}')
        self.mount = mount
        self.track = OdomTrack(history)
        self.reset()

    def reset(self) -> None:
        self.track.reset()
        self.first: float | None = None           # stamp of the first pose since the reset [s]
        self.last: float | None = None
        self.previous_end: np.ndarray | None = None  # the reader's odom pose at the end of the last MOVE used

    def problem(self, t: float) -> str | None:
        """Why a pose stamped ``t`` cannot be added (not after the last one), or None."""
        if self.last is not None and not t > self.last:
            return f'header.stamp: {t:.9f} s is not after the previous odometry {self.last:.9f} s'
        return None

    def add(self, t: float, pose: np.ndarray) -> None:
        """The pose (x, y, yaw) of base_link in odom at ``t``; call ``problem`` first."""
        self.track.add(t, pose)
        self.first = t if self.first is None else self.first
        self.last = t

    def gap(self, t0: float, t1: float) -> str | None:
        """Why odometry does not cover [t0, t1] (yet), or None when it does."""
        if not t1 >= t0:
            return f'the step ends ({t1:.9f} s) before it starts ({t0:.9f} s)'
        if self.last is None:
            return 'no odometry yet'
        if t0 < self.first or t0 < self.last - self.track.history:
            return f'no odometry at or before the step\'s start {t0:.9f} s (first {self.first:.9f} s)'
        if t1 > self.last:
            return f'no odometry at or after the step\'s end {t1:.9f} s (last {self.last:.9f} s)'
        return None

    def reader_at(self, t: float) -> np.ndarray:
        """The reader's pose in odom at ``t`` (base_link interpolated, then the mounting)."""
        return compose(self.track.pose_at(t), self.mount)

    def motion(self, t0: float, t1: float) -> MeasuredMotion:
        """The measured motion of the MOVE whose reads span [t0, t1] (covered: ``gap`` is None)."""
        return MeasuredMotion.between(self.reader_at(t0), self.reader_at(t1), self.previous_end)

    def used(self, t1: float) -> None:
        """The filter took the MOVE that ended at ``t1``: the next one's turns are counted from there."""
        self.previous_end = self.reader_at(t1)
