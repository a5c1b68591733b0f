"""Parameters of the ``slam`` node: its own, and the profiles that give the cekf.*/pf.*/hybrid.* defaults."""

from __future__ import annotations

from track_core.slam import HybridParams, PFParams, SlamParams
from track_core.slam.profiles import PROFILES
from track_msgs_py.topics import FRAME_LASER, FRAME_MAP
from track_msgs_py.validate import InputPolicy
from track_nodes.base import Param

#: (parameter prefix, core dataclass, profile attribute) of the core's configuration groups
CORE_GROUPS = (('cekf', SlamParams, 'slam'), ('pf', PFParams, 'pf'), ('hybrid', HybridParams, 'hybrid'))

PROFILE_PARAM = Param('profile', 'victoria_park', 'defaults of the cekf.*, pf.*, hybrid.* and pose0 parameters',
                      choices=tuple(PROFILES))


def node_params(pose0: list[float]) -> tuple[Param, ...]:
    return (
        Param('seed', 0, 'seed of the particle filter Generator', 0, 2**31 - 1),
        Param('pose0', pose0, 'initial laser pose [x m, y m, heading rad] in map'),
        Param('pose0_var', [1e-6, 1e-6, 1e-6], 'initial pose variances [m², m², rad²] (all > 0)'),
        Param('compressed', True, 'Compressed EKF (false: the full EKF; same result, slower)'),
        Param('add_radius', True, 'landmark = trunk centre: range + diameter/2 (victoria.load add_radius)'),
        Param('bearing_tolerance', 1e-6, 'bearings this far outside hybrid.bearing_limits are clipped, not '
              'dropped (float32 rounding) [rad]', 0.0, 0.1),
        Param('pause_wall', 0.2, 'a stream silent this long (wall) while the other delivered >= 2 messages no '
              'longer holds the other back [s]', 0.0, 60.0),
        Param('flush_idle', 0.5, 'process everything buffered after this long without a message (wall) [s]',
              0.01, 60.0),
        Param('drain_budget', 0.2, 'wall time one callback may spend on buffered events; the rest follows in the '
              'next callbacks (keeps the node responsive, e.g. to shutdown, during a backlog) [s]', 0.001, 60.0),
        Param('queue_depth', 100000, 'depth of the reliable input and scan subscriptions', 10, 1_000_000),
        Param('map_period', 2.0, 'publish the map at most every this much data time [s]; 0 = every scan',
              0.0, 3600.0),
        Param('ellipse_points', 16, 'points per 2σ landmark ellipse', 4, 360),
        Param('max_particles_published', 500, 'particles per PoseArray (an even subsample)', 1, 1_000_000),
        Param('warn_throttle', 5.0, 'at most one log line per kind of refused input per this many seconds [s]',
              0.0, 3600.0),
        Param('stamp_horizon', InputPolicy.horizon, 'refuse messages stamped more than this ahead of the node clock '
              '[s]', 1e-3, 1e9),
        Param('stamp_lead', 1.0, 'look-ahead tolerance: refuse messages stamped more than this ahead of the node '
              'clock (a few input periods; also late messages of a run before a clock jump) [s]', 1e-3, 1e9),
        Param('frame_id', FRAME_MAP, 'frame of the pose, map and particles'),
        Param('child_frame_id', FRAME_LASER, 'child_frame_id of the pose (the SLAM state is the laser pose)'),
    )
