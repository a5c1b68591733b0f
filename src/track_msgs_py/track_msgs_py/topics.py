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
