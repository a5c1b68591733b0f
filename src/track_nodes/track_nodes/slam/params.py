"""Parameters of the ``slam`` node: its own, and the core's configuration groups with the defaults of
its ``profile`` (``track_core.slam.profiles``)."""

from __future__ import annotations

from dataclasses import dataclass

from track_core.slam import HybridParams, PFParams, SlamParams, VehicleParams
from track_core.slam.profiles import PROFILES, SlamProfile
from track_core.slam.streams import BEARING_TOLERANCE
from track_msgs_py.topics import FRAME_BASE, FRAME_LASER, FRAME_MAP, FRAME_ODOM
from track_msgs_py.validate import InputPolicy
from track_nodes.base import group, param


def _profile(values):
    return PROFILES[values['profile']]()


@dataclass
class SlamNodeParams:
    """Parameters of ``slam``: ``profile`` first, since it gives the defaults of pose0, pose0_var and the groups."""

    profile: str = param('victoria_park', 'defaults of the cekf.*, pf.*, hybrid.*, pose0 and pose0_var parameters',
                         choices=tuple(PROFILES))
    seed: int = param(0, 'seed of the particle filter Generator', 0, 2**31 - 1)
    pose0: list[float] = param([0.0, 0.0, 0.0], 'initial pose [x m, y m, heading rad] in map: of the laser (the '
                               'filter state) with input_model acfr, of base_frame with odometry',
                               default_from=lambda v: list(_profile(v).pose0))
    pose0_var: list[float] = param(list(SlamProfile.pose0_var), 'initial pose variances [m², m², rad²] (all > 0)',
                                   default_from=lambda v: list(_profile(v).pose0_var))
    compressed: bool = param(True, 'Compressed EKF (false: the full EKF; same result, slower)')
    add_radius: bool = param(True, 'landmark = trunk centre: range + diameter/2 (victoria.load add_radius)')
    bearing_tolerance: float = param(BEARING_TOLERANCE, 'bearings this far outside hybrid.bearing_limits are '
                                     'clipped, not dropped (float32 rounding) [rad]', 0.0, 0.1)
    pause_wall: float = param(0.2, 'a stream silent this long (wall) while the other delivered >= 2 messages no '
                              'longer holds the other back [s]', 0.0, 60.0)
    flush_idle: float = param(0.5, 'process everything buffered after this long without a message (wall) [s]',
                              0.01, 60.0)
    drain_budget: float = param(0.2, 'wall time one callback may spend on buffered events; the rest follows in the '
                                'next callbacks (keeps the node responsive, e.g. to shutdown, during a backlog) [s]',
                                0.001, 60.0)
    queue_depth: int = param(100000, 'depth of the reliable input and scan subscriptions', 10, 1_000_000)
    map_period: float = param(2.0, 'publish the map at most every this much data time [s]; 0 = every scan', 0.0, 3600.0)
    ellipse_points: int = param(16, 'points per 2σ landmark ellipse', 4, 360)
    max_particles_published: int = param(500, 'particles per PoseArray (an even subsample)', 1, 1_000_000)
    warn_throttle: float = param(5.0, 'at most one log line per kind of refused input per this many seconds [s]',
                                 0.0, 3600.0)
    stamp_horizon: float = param(InputPolicy.horizon, 'refuse messages stamped more than this ahead of the node clock '
                                 '[s]', 1e-3, 1e9)
    stamp_lead: float = param(1.0, 'look-ahead tolerance: refuse messages stamped more than this ahead of the node '
                              'clock (a few input periods; also late messages of a run before a clock jump) [s]',
                              1e-3, 1e9)
    frame_id: str = param(FRAME_MAP, 'the map frame: frame of the pose, map and particles (parent of odom_frame)')
    child_frame_id: str = param(FRAME_LASER, 'the laser frame (the SLAM state is its position, with the robot '
                                'heading); detections must be in it')
    odom_frame: str = param(FRAME_ODOM, "the robot's odometry frame (REP-105): slam broadcasts frame_id -> odom_frame")
    base_frame: str = param(FRAME_BASE, "the robot's body frame, child of odom_frame (its driver's transform)")
    pose_of: str = param('base', 'frame whose pose /slam/pose and its twin /slam/pose/pose carry: base (base_frame, '
                         'REP-105) or laser (child_frame_id, the filter state)', choices=('base', 'laser'))
    input_model: str = param('acfr', 'motion input: acfr (/slam/inputs TwistStamped = encoder speed and steering '
                             'ANGLE of the ACFR car, geometry acfr.*) or odometry (nav_msgs/Odometry on /odom, '
                             'unicycle / differential-drive model)', choices=('acfr', 'odometry'))
    odometry_motion: str = param('increments', 'odometry: the motion between two messages from their poses '
                                 '(increments) or each message\'s twist (twist)', choices=('increments', 'twist'))
    odometry_noise: str = param('covariance', 'odometry: input noise from the twist covariance (v, yaw rate) when '
                                'the message has one, else cekf/pf sigma_v, sigma_steer (covariance); or always '
                                'the parameters (parameters)', choices=('covariance', 'parameters'))
    laser_pose: list[float] = param([0.0, 0.0, 0.0], 'odometry: the laser in base_frame [x m ahead, y m left, '
                                    'yaw rad] (acfr: at (acfr.a, acfr.b, 0))')
    observations: str = param('scan_cloud', 'observations: scan_cloud (/slam/scan PointCloud2, bearing 0 = right) or '
                              'detections (/slam/landmarks track_msgs/LandmarkDetectionArray, REP-103)',
                              choices=('scan_cloud', 'detections'))
    max_detections: int = param(500, 'refuse a scan or detection array with more entries than this (Victoria '
                                'Park: at most 18 trees a scan; each new entry can be a landmark of the state)',
                                1, 1_000_000)
    publish_odom_tf: bool = param(False, 'acfr inputs (no driver odometry): also broadcast odom_frame -> base_frame '
                                  'dead-reckoned from the inputs, as a driver would; never with odometry input')
    acfr: VehicleParams = group(VehicleParams)
    cekf: SlamParams = group(SlamParams, default_from=lambda v: _profile(v).slam)
    pf: PFParams = group(PFParams, default_from=lambda v: _profile(v).pf)
    hybrid: HybridParams = group(HybridParams, default_from=lambda v: _profile(v).hybrid)
