"""Typed records of the sonar scenario: the observer's filter, the target's status, the driver's messages.

- ``SonarFilterStatus``: ``/sonar/mode`` (``track_msgs/SonarFilterStatus``) per filter step: the reading
  it took, eq. 7's request for the next, whether it took a contact, the step, the ESS and, for ss-pf,
  the eq. 7 distance ‖P_D − Cov‖ (-1 for the baselines);
- ``SonarTargetStatus``: ``/sonar/target/status`` (``track_msgs/SonarTargetStatus``) per target step: the
  smart target's mode (naive|cruise|evade), whether it heard a ping at this step, and its counts;
- a sonar driver's messages: ``track_msgs/SonarContact`` ⇄ ``track_core.sonar.contacts.Contact``
  (bearing REP-103 in the contact's frame, the stds as the reading's noise R), the scheduler's
  ``track_msgs/SonarModeCommand``, and the own ship's navigation (REP-105 Odometry) ⇄ ``Fix``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from nav_msgs.msg import Odometry
from std_msgs.msg import Header

from track_core.sonar.contacts import Contact, Fix
from track_core.sonar.models import SensorMode
from track_msgs import msg as tm
from track_msgs_py.odometry import odometry_to_cv_state, orientation_matrix, yaw_to_quaternion
from track_msgs_py.records import RecordError, finite_value
from track_msgs_py.stamps import ns_to_stamp, stamp_to_ns, stamped_header
from track_msgs_py.validate import DEFAULT_POLICY, InputPolicy

TARGET_MODES = ('naive', 'cruise', 'evade')  # SonarTargetStatus.mode 0, 1, 2 (``SmartTarget.mode``)


@dataclass(frozen=True)
class SonarFilterStatus:
    """``/sonar/mode``: the observer's filter after one step (``track_msgs/SonarFilterStatus``)."""

    mode: SensorMode  # the reading the step took (a predict-only step: the last one's)
    next_mode: SensorMode  # eq. 7's request
    updated: bool  # False: a predict-only step
    step: int
    ess: float
    distance: float | None = None  # None: a fixed schedule

    def to_msg(self, key: int) -> tm.SonarFilterStatus:
        return tm.SonarFilterStatus(header=Header(stamp=ns_to_stamp(key)), mode=MODE_VALUES[self.mode],
                                    next_mode=MODE_VALUES[self.next_mode], updated=self.updated, step=self.step,
                                    ess=float(self.ess),
                                    distance=NO_DISTANCE if self.distance is None else float(self.distance))

    @classmethod
    def from_msg(cls, msg: tm.SonarFilterStatus) -> SonarFilterStatus:
        """``RecordError`` with one line for an unknown mode or a non-finite number."""
        kind = 'sonar filter status'
        d = finite_value(kind, 'distance', msg.distance)
        return cls(_mode(kind, msg.mode), _mode(kind, msg.next_mode), bool(msg.updated), int(msg.step),
                   finite_value(kind, 'ess', msg.ess), None if d < 0 else d)


@dataclass(frozen=True)
class SonarTargetStatus:
    """``/sonar/target/status``: the smart target after one step (``track_msgs/SonarTargetStatus``)."""

    mode: str  # naive | cruise | evade
    heard: bool
    pings: int
    detections: int

    def to_msg(self, t: float, target_id: str) -> tm.SonarTargetStatus:
        if self.mode not in TARGET_MODES:
            raise RecordError(f'sonar target status: mode {self.mode!r} is not one of {TARGET_MODES}')
        return tm.SonarTargetStatus(header=stamped_header(t, ''), target_id=target_id,
                                    mode=TARGET_MODES.index(self.mode), heard=self.heard, pings=self.pings,
                                    detections=self.detections)

    @classmethod
    def from_msg(cls, msg: tm.SonarTargetStatus) -> SonarTargetStatus:
        if msg.mode >= len(TARGET_MODES):
            raise RecordError(f'sonar target status: mode {msg.mode} is not NAIVE, CRUISE or EVADE (0-2)')
        return cls(TARGET_MODES[msg.mode], bool(msg.heard), int(msg.pings), int(msg.detections))


# --- a sonar driver's messages: contacts in, the scheduler's request out --------------------------
# SonarContact / SonarModeCommand mode values ⇄ the core's SensorMode
MODE_VALUES = {SensorMode.PASSIVE: tm.SonarContact.PASSIVE, SensorMode.ACTIVE: tm.SonarContact.ACTIVE}
_MODES = {v: k for k, v in MODE_VALUES.items()}
MAX_BEARING_STD = math.pi  # a bearing std beyond half a turn says nothing
NO_DISTANCE = -1.0  # SonarModeCommand.distance at start and for a fixed schedule (no eq. 7 distance)


def _mode(kind: str, value: int) -> SensorMode:
    if value not in _MODES:
        raise RecordError(f'{kind}: mode {value} is neither PASSIVE (0) nor ACTIVE (1)')
    return _MODES[value]


def contact_to_msg(c: Contact, frame_id: str) -> tm.SonarContact:
    """A core ``Contact`` → ``track_msgs/SonarContact`` in ``frame_id`` (stamp = ``c.key`` exactly)."""
    active = c.mode is SensorMode.ACTIVE
    std = np.sqrt(np.diag(c.R))
    return tm.SonarContact(header=Header(stamp=ns_to_stamp(c.key), frame_id=frame_id), mode=MODE_VALUES[c.mode],
                           bearing=float(c.yaw), bearing_std=float(std[0]),
                           range=float(c.range) if active else 0.0, range_std=float(std[1]) if active else 0.0)


def contact_from_msg(msg: tm.SonarContact, relative: bool, policy: InputPolicy = DEFAULT_POLICY) -> Contact:
    """``track_msgs/SonarContact`` → ``Contact`` (``relative``: its frame is the ship's body frame), or
    ``RecordError`` with one line: an unknown mode, a non-finite or out-of-range bearing, range or std."""
    kind = 'sonar contact'
    mode = _mode(kind, msg.mode)
    b = finite_value(kind, 'bearing', msg.bearing)
    if abs(b) > 4.0 * math.pi:
        raise RecordError(f'{kind}: bearing {b} rad is beyond ±4π (degrees sent as radians?)')
    sb = finite_value(kind, 'bearing_std', msg.bearing_std)
    if not 1e-9 < sb <= MAX_BEARING_STD:
        raise RecordError(f'{kind}: bearing_std {sb} rad is not in (1e-9, π]')
    if mode is SensorMode.ACTIVE:
        r, sr = finite_value(kind, 'range', msg.range), finite_value(kind, 'range_std', msg.range_std)
        if not 0.0 <= r <= policy.world_bound:
            raise RecordError(f'{kind}: range {r} m is not in [0, {policy.world_bound:g}]')
        if not 1e-6 < sr <= policy.world_bound:
            raise RecordError(f'{kind}: range_std {sr} m is not in (1e-6, {policy.world_bound:g}]')
        R = np.diag([sb * sb, sr * sr])
    else:
        r, R = math.nan, np.array([[sb * sb]])
    return Contact(stamp_to_ns(msg.header.stamp), mode, b, r, R, relative)


def mode_command_to_msg(key: int, mode: SensorMode, distance: float | None) -> tm.SonarModeCommand:
    """The scheduler's request for the next reading, stamped with the filter time ``key`` [ns] (0: at start);
    ``distance`` None (at start, a fixed schedule) is written as ``NO_DISTANCE``."""
    return tm.SonarModeCommand(header=Header(stamp=ns_to_stamp(key)), mode=MODE_VALUES[mode],
                               distance=NO_DISTANCE if distance is None else float(distance))


def mode_command_from_msg(msg: tm.SonarModeCommand) -> tuple[int, SensorMode]:
    """(stamp [ns], requested mode), or ``RecordError`` for an unknown mode."""
    return stamp_to_ns(msg.header.stamp), _mode('sonar mode command', msg.mode)


def fix_from_odometry(msg: Odometry) -> Fix:
    """Own-ship navigation (``nav_msgs/Odometry``, REP-105: pose in ``header.frame_id``, twist in
    ``child_frame_id``) → ``Fix`` in the world frame: position, velocity and the heading of the pose."""
    _, x, _ = odometry_to_cv_state(msg)
    q = msg.pose.pose.orientation
    R = orientation_matrix(q)
    heading = 0.0 if R is None else math.atan2(R[1, 0], R[0, 0])
    return Fix(stamp_to_ns(msg.header.stamp), x[[0, 2]], x[[1, 3]], heading)


def fix_to_odometry(key: int, xy: np.ndarray, velocity: np.ndarray, frame_id: str, child_frame_id: str) -> Odometry:
    """A ship at ``xy`` moving at ``velocity`` (world frame) → REP-105 Odometry: heading along the velocity
    (identity when at rest), forward speed in ``twist.linear.x`` of ``child_frame_id``; zero covariance."""
    msg = Odometry(header=Header(stamp=ns_to_stamp(key), frame_id=frame_id), child_frame_id=child_frame_id)
    msg.pose.pose.position.x, msg.pose.pose.position.y = float(xy[0]), float(xy[1])
    speed = float(np.hypot(velocity[0], velocity[1]))
    heading = math.atan2(velocity[1], velocity[0]) if speed > 0 else 0.0
    msg.pose.pose.orientation.z, msg.pose.pose.orientation.w = yaw_to_quaternion(heading)
    msg.twist.twist.linear.x = speed
    return msg
