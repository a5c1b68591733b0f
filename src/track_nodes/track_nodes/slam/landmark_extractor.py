"""``landmark_extractor``: point landmarks (trunks, poles, posts) from a planar laser scan, for ``slam``.

Subscribes to ``/scan`` (sensor_msgs/LaserScan, sensor QoS: best effort, so it matches any laser
driver) and publishes, for every scan, ``/slam/landmarks`` (track_msgs/LandmarkDetectionArray,
``records.landmarks.LandmarkDetections``, reliable): the scan's header (stamp and laser frame) and one
detection per trunk or pole found by ``track_core.slam.landmarks.extract`` (range to the centre,
REP-103 bearing, diameter, their 3×3 covariance; identities unknown). A scan without landmarks gives
an empty array, so the filter still sees the instant.

Parameters: ``max_beams`` (a scan with more beams is refused) and every field of
``landmarks.ExtractorParams`` as ``extractor.*`` (segmentation jump, point counts, diameter limits,
circle-fit residual, the laser's range noise).

Bad input (``refuse``: counted, one throttled line, on /diagnostics; nothing published): a scan that
``LaserScanData.from_msg`` cannot read (more than ``max_beams`` beams, a zero or non-finite angle
increment, more than one turn, range limits that are not 0 ≤ min < max), a malformed stamp, or one
more than ``stamp_horizon`` ahead of the node clock. Beams with NaN, ±inf or out-of-limit ranges are
not errors (REP-117); the extractor reads them as no return or unknown.
"""

from __future__ import annotations

from dataclasses import dataclass

from sensor_msgs.msg import LaserScan

from track_core.slam.landmarks import ExtractorParams, extract
from track_msgs_py.qos import qos_for_topic
from track_msgs_py.records import RecordError
from track_msgs_py.records.landmarks import LandmarkDetections, LaserScanData
from track_msgs_py.stamps import stamp_to_ns
from track_msgs_py.topics import SLAM_LANDMARKS, SLAM_LASER_SCAN
from track_msgs_py.validate import InputPolicy, clock_now, stamp_problem
from track_nodes.base import TrackNode, group, param


@dataclass
class LandmarkExtractorParams:
    """Parameters of ``landmark_extractor``."""

    max_beams: int = param(100_000, 'refuse a scan with more beams than this', 1, 10_000_000)
    stamp_horizon: float = param(InputPolicy.horizon, 'refuse scans stamped more than this ahead of the node clock '
                                 '[s]', 1e-3, 1e9)
    warn_throttle: float = param(5.0, 'at most one log line per kind of refused scan per this many seconds [s]',
                                 0.0, 3600.0)
    extractor: ExtractorParams = group(ExtractorParams)


class LandmarkExtractorNode(TrackNode):
    DEFAULT_NAME = 'landmark_extractor'
    Params = LandmarkExtractorParams
    p: LandmarkExtractorParams

    def setup(self) -> None:
        self.policy = InputPolicy(horizon=self.p.stamp_horizon)
        self.refusals.throttle = self.p.warn_throttle
        self.n_scans = self.n_detections = 0
        self.pub = self.create_publisher(LandmarkDetections.msg_type(), SLAM_LANDMARKS, qos_for_topic(SLAM_LANDMARKS))
        self.create_subscription(LaserScan, SLAM_LASER_SCAN, self._on_scan, qos_for_topic(SLAM_LASER_SCAN))

    def _on_scan(self, msg: LaserScan) -> None:
        stamp = msg.header.stamp
        try:
            if not 0 <= stamp.nanosec < 1_000_000_000:
                raise RecordError(f'header.stamp: malformed stamp (nanosec {stamp.nanosec})')
            scan = LaserScanData.from_msg(msg, self.p.max_beams)
        except RecordError as exc:
            self.refuse(SLAM_LASER_SCAN, str(exc))
            return
        reason = stamp_problem(stamp_to_ns(stamp) / 1e9, clock_now(self.get_clock().now().nanoseconds), self.policy,
                               required=False)
        if reason:
            self.refuse(SLAM_LASER_SCAN, reason)
            return
        det = extract(scan.ranges, scan.angle_min, scan.angle_increment, scan.range_min, scan.range_max,
                      self.p.extractor)
        out = LandmarkDetections.from_detections(scan.t, scan.frame_id, det).to_msg()
        out.header = msg.header   # the scan's own stamp, exactly
        self.pub.publish(out)
        self.n_scans += 1
        self.n_detections += len(det)
