"""The reader side's topics for readers that are not the simulator (``rfid_log_reader``, ``rfid_llrp_reader``).

Not a node: the publishers and the order of ``rfid_reader`` (``/rfid/phase`` of a MOVE, then the truth
``/rfid/user/pose`` + ``/tf`` and ``/rfid/user/status`` when there is one, then ``/rfid/step`` last; the
phase cloud and the step result with one stamp), and ``/tf_static`` placing the reader's frame (the node
name) at the user, so a display, a recorder and ``rfid_guidance`` see the same topics whichever reader runs.
"""

from __future__ import annotations

import math

import numpy as np
from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import PointCloud2

from track_core.rfid.protocol import CommandKind, StepResult
from track_core.rfid.signal import PhaseStream
from track_msgs.msg import RfidStep as RfidStepMsg
from track_msgs.msg import RfidUserStatus as RfidUserStatusMsg
from track_msgs_py.qos import ESTIMATE_QOS
from track_msgs_py.records.rfid import RfidPhase, RfidStep, RfidUserStatus
from track_msgs_py.stamps import sec_to_stamp
from track_msgs_py.tf import planar_transform, pose_transform
from track_msgs_py.topics import (
    FRAME_MAP,
    RFID_FRAME_USER,
    RFID_PHASE,
    RFID_STEP,
    RFID_USER_POSE,
    RFID_USER_STATUS,
)


def pose_stamped(t: float, pose: np.ndarray) -> PoseStamped:
    """(x, y, heading) in ``map`` at ``t`` (a NaN heading: facing +x)."""
    msg = PoseStamped()
    msg.header.stamp, msg.header.frame_id = sec_to_stamp(t), FRAME_MAP
    head = float(pose[2]) if math.isfinite(pose[2]) else 0.0
    msg.pose.position.x, msg.pose.position.y = float(pose[0]), float(pose[1])
    msg.pose.orientation.z, msg.pose.orientation.w = math.sin(0.5 * head), math.cos(0.5 * head)
    return msg


class ReaderTopics:
    """The publishers of the reader side on ``node`` (a ``TrackNode``), made at once (a recorder sees them)."""

    def __init__(self, node, carrier_hz: float) -> None:
        self.node = node
        self.carrier_hz = carrier_hz
        node.add_static_transforms(planar_transform(0.0, RFID_FRAME_USER, node.get_name(), 0.0, 0.0, 0.0))
        node.advertise_transforms()
        self.phase = node.create_publisher(PointCloud2, RFID_PHASE, ESTIMATE_QOS)
        self.pose = node.create_publisher(PoseStamped, RFID_USER_POSE, ESTIMATE_QOS)
        self.status = node.create_publisher(RfidUserStatusMsg, RFID_USER_STATUS, ESTIMATE_QOS)
        self.step = node.create_publisher(RfidStepMsg, RFID_STEP, ESTIMATE_QOS)

    def publish(self, t: float, result: StepResult, stream: PhaseStream, duration: float,
                truth: RfidUserStatus | None = None) -> None:
        """One answer, stamped ``t``: the MOVE's reads, the truth if known, the step result last."""
        if result.kind is CommandKind.MOVE:
            at = np.zeros(2) if truth is None else np.array([truth.x, truth.y])
            t_start = stream.t_start if stream.t_start is not None else (float(stream.t[0]) if len(stream) else 0.0)
            self.phase.publish(RfidPhase.from_stream(t, stream, t_start, self.carrier_hz, at).to_msg())
        if truth is not None:
            pose = pose_stamped(t, np.array([truth.x, truth.y, truth.heading]))
            self.node.send_transforms(pose_transform(pose.header, pose.pose, RFID_FRAME_USER))
            self.pose.publish(pose)
            self.status.publish(truth.to_msg(t))
        self.step.publish(RfidStep.from_result(result, duration).to_msg(t))
