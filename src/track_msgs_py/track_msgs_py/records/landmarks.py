"""Point landmarks and robot motion in standard and ``track_msgs`` messages, for the ``slam`` node.

=======================================  ==================================================================
data                                     message and fields
=======================================  ==================================================================
detections of one instant                ``track_msgs/LandmarkDetectionArray``: ``range`` [m, to the centre],
(``LandmarkDetections``)                 ``bearing`` [rad, REP-103: 0 ahead, CCW +], ``diameter`` [m],
                                         ``covariance`` (9 per detection: (range, bearing, diameter) row-major),
                                         ``id`` (``UNKNOWN_ID`` = -1, or empty: all unknown); frame = the sensor
the landmark map (``LandmarkMap``)       ``track_msgs/LandmarkMap``: ``id``, ``x``, ``y`` [m in map],
                                         ``covariance`` (4 per landmark, (x, y) row-major)
a planar laser scan (``LaserScanData``)  ``sensor_msgs/LaserScan``: ranges, angle_min, angle_increment,
                                         range_min, range_max (REP-117: +inf = no return)
the robot's odometry (``PlanarOdometry``) ``nav_msgs/Odometry`` read per REP-105: the pose of child_frame_id
                                         (base_link) in header.frame_id (odom), yaw of its orientation;
                                         the twist in child_frame_id: v = linear.x, ω = angular.z; their
                                         covariance = entries (0, 0), (0, 5), (5, 5) of the 6×6 twist
                                         covariance, ``None`` when all three are 0 (a driver that fills none)
=======================================  ==================================================================

``from_msg`` raises ``RecordError`` with one line naming the field for a message that cannot be
read (column lengths that differ, more entries than the caller's cap, a covariance that is not
symmetric PSD, a zero or non-finite angle increment). Non-finite values in single rows are left to
the caller's row rules (``track_core.slam.streams``), so one bad detection does not cost a scan.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Self

import numpy as np

from track_msgs_py.odometry import quaternion_yaw
from track_msgs_py.records import RecordError
from track_msgs_py.stamps import stamp_to_sec, stamped_header


def _column(msg, name: str, n: int | None, cap: int, kind: str) -> np.ndarray:
    a = np.asarray(getattr(msg, name), dtype=float)
    if a.size > cap:
        raise RecordError(f'{kind}: {name} has {a.size} entries, more than the cap {cap}')
    if n is not None and a.size != n:
        raise RecordError(f'{kind}: {name} has {a.size} entries, range has {n}')
    return a


@dataclass(frozen=True)
class LandmarkDetections:
    """One ``track_msgs/LandmarkDetectionArray`` (module table)."""

    t: float
    frame_id: str
    range: np.ndarray
    bearing: np.ndarray
    diameter: np.ndarray
    covariance: np.ndarray   # (n, 3, 3)
    id: np.ndarray           # (n,) int, UNKNOWN_ID = -1

    KIND = 'landmark detections'

    @staticmethod
    def msg_type():
        from track_msgs.msg import LandmarkDetectionArray

        return LandmarkDetectionArray

    def to_msg(self):
        from track_msgs.msg import LandmarkDetectionArray

        n = self.range.size
        return LandmarkDetectionArray(
            header=stamped_header(self.t, self.frame_id), range=self.range.astype(float).tolist(),
            bearing=self.bearing.astype(float).tolist(), diameter=self.diameter.astype(float).tolist(),
            covariance=np.asarray(self.covariance, dtype=float).reshape(n * 9).tolist(),
            id=np.asarray(self.id, dtype=np.int32).tolist())

    @classmethod
    def from_detections(cls, t: float, frame_id: str, det) -> Self:
        """From ``track_core.slam.landmarks.Detections`` (identities unknown)."""
        return cls(t, frame_id, det.range, det.bearing, det.diameter, det.covariance,
                   np.full(det.range.size, -1, dtype=np.int32))

    @classmethod
    def from_msg(cls, msg, max_size: int = 10_000) -> Self:
        k = cls.KIND
        r = _column(msg, 'range', None, max_size, k)
        n = r.size
        b = _column(msg, 'bearing', n, max_size, k)
        d = _column(msg, 'diameter', n, max_size, k)
        c = np.asarray(msg.covariance, dtype=float)
        if c.size != 9 * n:
            raise RecordError(f'{k}: covariance has {c.size} entries, need 9 per detection ({9 * n})')
        c = c.reshape(n, 3, 3)
        ids = np.asarray(msg.id, dtype=np.int64)
        if ids.size not in (0, n):
            raise RecordError(f'{k}: id has {ids.size} entries, need 0 or {n}')
        with np.errstate(invalid='ignore'):
            finite = np.isfinite(c).all(axis=(1, 2))
            bad = finite & ~(np.all(np.abs(c - np.swapaxes(c, 1, 2)) <= 1e-9 * (1 + np.abs(c)), axis=(1, 2)))
        if bad.any():
            raise RecordError(f'{k}: covariance of detection {int(np.flatnonzero(bad)[0])} is not symmetric')
        if finite.any() and np.any(np.linalg.eigvalsh(c[finite])[:, 0] < -1e-12):
            raise RecordError(f'{k}: a covariance is not positive semi-definite')
        return cls(stamp_to_sec(msg.header.stamp), msg.header.frame_id, r, b, d, c,
                   np.full(n, -1, np.int32) if ids.size == 0 else ids.astype(np.int32))


@dataclass(frozen=True)
class LandmarkMap:
    """One ``track_msgs/LandmarkMap`` (module table): means (L, 2) and covariances (L, 2, 2) in ``frame_id``."""

    t: float
    frame_id: str
    id: np.ndarray
    xy: np.ndarray
    covariance: np.ndarray

    KIND = 'landmark map'

    @staticmethod
    def msg_type():
        from track_msgs.msg import LandmarkMap as LandmarkMapMsg

        return LandmarkMapMsg

    def to_msg(self):
        from track_msgs.msg import LandmarkMap as LandmarkMapMsg

        xy = np.asarray(self.xy, dtype=float).reshape(-1, 2)
        return LandmarkMapMsg(header=stamped_header(self.t, self.frame_id),
                              id=np.asarray(self.id, dtype=np.uint32).tolist(), x=xy[:, 0].tolist(),
                              y=xy[:, 1].tolist(), covariance=np.asarray(self.covariance, float).reshape(-1).tolist())

    @classmethod
    def from_msg(cls, msg) -> Self:
        x, y = np.asarray(msg.x, dtype=float), np.asarray(msg.y, dtype=float)
        ids, c = np.asarray(msg.id, dtype=np.int64), np.asarray(msg.covariance, dtype=float)
        if not (x.size == y.size == ids.size and c.size == 4 * x.size):
            raise RecordError(f'{cls.KIND}: column lengths differ (id {ids.size}, x {x.size}, y {y.size}, '
                              f'covariance {c.size} = 4 per landmark?)')
        return cls(stamp_to_sec(msg.header.stamp), msg.header.frame_id, ids, np.stack([x, y], axis=1),
                   c.reshape(-1, 2, 2))


@dataclass(frozen=True)
class LaserScanData:
    """The fields of a ``sensor_msgs/LaserScan`` the landmark extractor reads."""

    t: float
    frame_id: str
    ranges: np.ndarray
    angle_min: float
    angle_increment: float
    range_min: float
    range_max: float

    KIND = 'laser scan'

    @classmethod
    def from_msg(cls, msg, max_beams: int = 100_000) -> Self:
        k = cls.KIND
        n = len(msg.ranges)
        if n > max_beams:
            raise RecordError(f'{k}: ranges has {n} beams, more than the cap {max_beams}')
        a0, inc, rmin, rmax = (float(v) for v in (msg.angle_min, msg.angle_increment, msg.range_min, msg.range_max))
        if not (math.isfinite(a0) and math.isfinite(inc) and inc != 0.0 and abs(inc) * max(n, 1) <= 2 * math.pi + 1e-6):
            raise RecordError(f'{k}: angle_min {a0!r} / angle_increment {inc!r}: need finite numbers, a non-zero '
                              'increment and at most one turn')
        if not (math.isfinite(rmin) and rmin >= 0 and rmax > rmin):
            raise RecordError(f'{k}: range_min {rmin!r} / range_max {rmax!r}: need 0 <= range_min < range_max')
        return cls(stamp_to_sec(msg.header.stamp), msg.header.frame_id, np.asarray(msg.ranges, dtype=float),
                   a0, inc, rmin, rmax)


@dataclass(frozen=True)
class PlanarOdometry:
    """A ``nav_msgs/Odometry`` read per REP-105 (module table)."""

    t: float
    frame_id: str
    child_frame_id: str
    pose: np.ndarray              # (x, y, yaw) of child_frame_id in frame_id
    v: float                      # forward speed, twist.linear.x in child_frame_id [m/s]
    w: float                      # yaw rate, twist.angular.z [rad/s]
    cov: np.ndarray | None        # 2×2 covariance of (v, ω), or None when the driver filled none

    @classmethod
    def from_msg(cls, msg) -> Self:
        """Call ``validate.odometry_problem`` first (finite numbers, unit quaternion, 36-entry covariances)."""
        p = msg.pose.pose.position
        yaw = quaternion_yaw(msg.pose.pose.orientation)
        tc = np.asarray(msg.twist.covariance, dtype=float)
        cov = np.array([[tc[0], tc[5]], [tc[30], tc[35]]])
        if not np.any(cov):
            cov = None
        elif (abs(cov[0, 1] - cov[1, 0]) > 1e-9 * (abs(cov[0, 1]) + abs(cov[1, 0]) + 1e-300) or cov[0, 0] < 0
              or cov[1, 1] < 0 or cov[0, 0] * cov[1, 1] < cov[0, 1] * cov[1, 0] * (1 - 1e-9)):
            raise RecordError(f'odometry: twist.covariance (v, yaw rate) block {cov.ravel().tolist()} is not a '
                              'symmetric PSD 2x2')
        return cls(stamp_to_sec(msg.header.stamp), msg.header.frame_id, msg.child_frame_id,
                   np.array([p.x, p.y, yaw]), float(msg.twist.twist.linear.x), float(msg.twist.twist.angular.z), cov)


def planar_odometry_msg(t: float, pose: np.ndarray, v: float, w: float, cov: np.ndarray | None,
                        frame_id: str, child_frame_id: str):
    """A driver's ``nav_msgs/Odometry`` of a planar robot: pose (x, y, yaw) of ``child_frame_id`` in ``frame_id``,
    twist (v, ω) in ``child_frame_id`` with the 2×2 covariance ``cov`` at entries (0,0), (0,5), (5,5) (the
    converter of the Victoria Park run and the tests; the inverse of ``PlanarOdometry.from_msg``)."""
    from nav_msgs.msg import Odometry

    msg = Odometry(header=stamped_header(t, frame_id), child_frame_id=child_frame_id)
    msg.pose.pose.position.x, msg.pose.pose.position.y = float(pose[0]), float(pose[1])
    msg.pose.pose.orientation.z, msg.pose.pose.orientation.w = math.sin(pose[2] / 2), math.cos(pose[2] / 2)
    msg.twist.twist.linear.x, msg.twist.twist.angular.z = float(v), float(w)
    if cov is not None:
        tc = np.zeros(36)
        tc[0], tc[5], tc[30], tc[35] = cov[0, 0], cov[0, 1], cov[1, 0], cov[1, 1]
        msg.twist.covariance = tc
    return msg
