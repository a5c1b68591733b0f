"""Topic names, their message types and QoS kinds, and the frames we know.

One table (``TOPICS``) instead of string literals scattered over nodes: the recorder, the
player and the QoS lookup (``qos.qos_for_topic``) all read it, so a topic added here is
recorded and replayed with the right type and QoS without touching them. Later issues
extend ``TOPICS`` (one entry per topic) and ``KNOWN_FRAMES``.

QoS kinds (profiles in ``track_msgs_py.qos``): ``'sensor'`` best-effort depth 5,
``'estimate'`` reliable depth 10, ``'static'`` reliable transient-local depth 1, and
``'clock'`` for ``/clock`` (compatible with rclpy's own /clock subscription).
"""

from __future__ import annotations

from typing import Literal, NamedTuple

QosKind = Literal['sensor', 'estimate', 'static', 'clock']

# Frames (REP-103/105): ENU, SI units. ``map`` is the only world frame of the package set.
FRAME_MAP = 'map'
KNOWN_FRAMES: frozenset[str] = frozenset({FRAME_MAP})

# Foundation demo: a constant-velocity target, noisy position reports, a Kalman tracker.
DEMO_TRUTH = '/demo/truth'
DEMO_REPORTS = '/demo/reports'
DEMO_TRACK = '/demo/track'
CLOCK = '/clock'

# Track-to-track fusion (geofeasibility paper). Input track topics are parameters of the node.
FUSION_SCORES = '/fusion/scores'
FUSION_ASSOCIATIONS = '/fusion/associations'
FUSION_FUSED = '/fusion/fused'
FUSION_MARKERS = '/fusion/markers'


class TopicSpec(NamedTuple):
    """What travels on a topic: full type name (``pkg/msg/Type``), QoS kind, one-line description."""

    msgtype: str
    qos: QosKind
    description: str


TOPICS: dict[str, TopicSpec] = {
    CLOCK: TopicSpec('rosgraph_msgs/msg/Clock', 'clock', 'simulated time, driven by the launcher or the player'),
    DEMO_TRUTH: TopicSpec('nav_msgs/msg/Odometry', 'estimate',
                          'true CV state of the demo target (zero covariance); child_frame_id = track id'),
    DEMO_REPORTS: TopicSpec('geometry_msgs/msg/PoseWithCovarianceStamped', 'sensor',
                            'noisy position report of the demo target with its measurement covariance R'),
    DEMO_TRACK: TopicSpec('nav_msgs/msg/Odometry', 'estimate',
                          'Kalman estimate of the demo target; child_frame_id = track id'),
    FUSION_SCORES: TopicSpec('diagnostic_msgs/msg/DiagnosticArray', 'estimate',
                             'one status per track pair: name "A | B", values score, combined, instants, '
                             'associated, method'),
    FUSION_ASSOCIATIONS: TopicSpec('diagnostic_msgs/msg/DiagnosticArray', 'estimate',
                                   'the associated pairs only (combined score >= threshold), same layout'),
    FUSION_FUSED: TopicSpec('nav_msgs/msg/Odometry', 'estimate',
                            'covariance-intersection fusion of an associated pair; child_frame_id = "A+B"'),
    FUSION_MARKERS: TopicSpec('visualization_msgs/msg/MarkerArray', 'estimate',
                              '2σ ellipses of the live tracks and pair links coloured by score'),
}

# Sonar observer vs smart target (smart-target sensor-scheduling paper, issue 3).
SONAR_TRUTH = '/sonar/target/truth'
SONAR_TARGET_STATUS = '/sonar/target/status'
SONAR_OBSERVER = '/sonar/observer/odom'
SONAR_ESTIMATE = '/sonar/estimate'
SONAR_PARTICLES = '/sonar/particles'
SONAR_MODE = '/sonar/mode'
SONAR_PING = '/sonar/ping'
SONAR_MARKERS = '/sonar/markers'

TOPICS.update({
    SONAR_TRUTH: TopicSpec('nav_msgs/msg/Odometry', 'estimate',
                           'true state of the smart target (zero covariance), stamped t_k = k·T; '
                           'child_frame_id = target id'),
    SONAR_TARGET_STATUS: TopicSpec('diagnostic_msgs/msg/DiagnosticArray', 'estimate',
                                   'smart target after step k: one status "<target id>", values mode '
                                   '(naive|cruise|evade), heard (a ping at t_{k-1} was detected: true|false), '
                                   'pings, detections (totals so far)'),
    SONAR_OBSERVER: TopicSpec('nav_msgs/msg/Odometry', 'estimate',
                              'observer AUV state at t_k (zero covariance); published last in its step, so it '
                              'also marks "observer step k done" for the smart target'),
    SONAR_ESTIMATE: TopicSpec('nav_msgs/msg/Odometry', 'estimate',
                              'SS-PF/PaPF/AcPF estimate of the target with its particle covariance; '
                              'child_frame_id = track id'),
    SONAR_PARTICLES: TopicSpec('geometry_msgs/msg/PoseArray', 'sensor',
                               'selected particles after step k (positions, identity orientation, equal weights)'),
    SONAR_MODE: TopicSpec('diagnostic_msgs/msg/DiagnosticArray', 'estimate',
                          'sensor schedule: one status "<node>/sensor_mode", message = mode used at t_k, values '
                          'mode, next_mode (eq. 7 choice for t_{k+1}), step, ess, distance (‖P_D − Cov‖, ss-pf)'),
    SONAR_PING: TopicSpec('geometry_msgs/msg/PointStamped', 'estimate',
                          'active-ping event: the observer pinged at header.stamp from point (x, y, 0)'),
    SONAR_MARKERS: TopicSpec('visualization_msgs/msg/MarkerArray', 'estimate',
                             '2σ position ellipse of the sonar estimate (ns "sonar_estimate", id 0)'),
})
