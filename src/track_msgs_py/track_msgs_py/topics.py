"""Topic names, their message types and QoS kinds, and the frames we know.

One table (``TOPICS``): the recorder, the player and the QoS lookup (``qos.qos_for_topic``) read
it, so a new topic is one more entry of ``TOPICS`` (and its frames of ``KNOWN_FRAMES``).

Names here are as they resolve in the root namespace (what a bag of an un-namespaced run holds).
Nodes use them through ``relative``: without the leading slash, so ``-r __ns:=/robot1`` puts a
node's topics under ``/robot1`` and remapping rules apply. The ROS-wide topics
(``GLOBAL_TOPICS``: /clock, /tf, /tf_static, /diagnostics, ...) stay absolute, as in ROS itself.

QoS kinds (profiles in ``track_msgs_py.qos``): ``'sensor'`` best-effort depth 5,
``'estimate'`` reliable depth 10, ``'static'`` reliable transient-local depth 1, and
``'clock'`` for ``/clock`` (compatible with rclpy's own /clock subscription), ``'tf'`` and
``'tf_static'`` for the transform tree (``track_msgs_py.tf``: tf2_ros's profiles).

Covariances (``COV_PLANAR`` in the entries below; ``track_msgs_py.covariance``). Every
``Odometry`` and ``PoseWithCovarianceStamped`` we publish is planar. The x/y block is the estimate
(0 on truth topics; ``covariance.xy_block``); z, roll, pitch (twist: vz, ωx, ωy) exactly 0 (a flat
2σ ellipse in RViz 2 and Foxglove); an entry not estimated is 1e6 (``NOT_ESTIMATED_VARIANCE``,
``covariance.not_estimated``). How messages are filled: ``track_msgs_py.odometry``.

Point clouds (``CLOUD_XYZ``; ``track_msgs_py.clouds``). Every ``PointCloud2`` we publish starts
with float32 ``x``, ``y``, ``z`` at offsets 0, 4, 8, which RViz and Foxglove need to draw it (the
sensor_msgs point_cloud2 convention); the table's own fields follow. Each cloud's fields are
defined by its typed record: ``records.slam.SlamScan``, ``records.rfid.RfidPhase``,
``records.idsq.IdsqBelief``, and ``records.idsq.layout_to_pointcloud2`` for ``/idsq/layout``.

``track_msgs_py.display`` checks both conventions on a message; ``track-bag-check BAG`` on a recording.
"""

from typing import Literal, NamedTuple

QosKind = Literal['sensor', 'estimate', 'static', 'clock', 'tf', 'tf_static']

# Frames (REP-103/105): ENU, SI units. ``map`` is the only world frame of the package set.
FRAME_MAP = 'map'
KNOWN_FRAMES: frozenset[str] = frozenset({FRAME_MAP})

# Foundation demo: a constant-velocity target, noisy position reports, a Kalman tracker.
DEMO_TRUTH = '/demo/truth'
DEMO_REPORTS = '/demo/reports'
DEMO_TRACK = '/demo/track'
CLOCK = '/clock'
# The transform tree (track_msgs_py.tf): absolute names, as tf2_ros uses them.
TF = '/tf'
TF_STATIC = '/tf_static'
DIAGNOSTICS = '/diagnostics'  # the standard ROS health topic: every node's counts of refused input
READY = '/track/ready'  # every node's announcement once it is up (records.ready), one transient-local sample each

# Track-to-track fusion (geofeasibility paper). Input track topics are parameters of the node.
FUSION_SCORES = '/fusion/scores'
FUSION_ASSOCIATIONS = '/fusion/associations'
FUSION_FUSED = '/fusion/fused'
FUSION_MARKERS = '/fusion/markers'

GLOBAL_TOPICS = frozenset({CLOCK, DIAGNOSTICS, READY, '/tf', '/tf_static', '/rosout', '/parameter_events'})


def relative(topic: str) -> str:
    """The name a node gives for one of our topics: relative (no leading '/'), unless a ROS-wide one."""
    return topic if topic in GLOBAL_TOPICS or not topic.startswith('/') else topic[1:]


#: The covariance layout of every Odometry / PoseWithCovarianceStamped we publish (see the module docstring).
COV_PLANAR = 'planar covariance: x/y block = estimate, z/roll/pitch 0, not estimated = 1e6'
#: The point layout every PointCloud2 we publish starts with.
CLOUD_XYZ = 'float32 x, y, z at offsets 0/4/8, then'


class TopicSpec(NamedTuple):
    """What travels on a topic: full type name (``pkg/msg/Type``), QoS kind, one-line description."""

    msgtype: str
    qos: QosKind
    description: str


TOPICS: dict[str, TopicSpec] = {
    CLOCK: TopicSpec('rosgraph_msgs/msg/Clock', 'clock', 'simulated time, driven by the launcher or the player'),
    TF: TopicSpec('tf2_msgs/msg/TFMessage', 'tf', 'dynamic transforms, stamped at the data they place '
                  '(track_nodes.base.TrackNode.send_transforms)'),
    TF_STATIC: TopicSpec('tf2_msgs/msg/TFMessage', 'tf_static', 'fixed transforms: one latched message per '
                         'publisher carrying all of them (TrackNode.add_static_transforms)'),
    DIAGNOSTICS: TopicSpec('diagnostic_msgs/msg/DiagnosticArray', 'estimate',
                           'per node: refused input counted per "<topic> <reason field>" (track_nodes.base.node)'),
    READY: TopicSpec('diagnostic_msgs/msg/DiagnosticStatus', 'static',
                     'one status per node once it is up, named after the node: pid, host, start, executable '
                     '(track_msgs_py.records.ready; track_nodes.base.ready)'),
    DEMO_TRUTH: TopicSpec('nav_msgs/msg/Odometry', 'estimate',
                          'true CV state of the demo target (zero x/y covariance, yaw 1e6); child_frame_id = track id'),
    DEMO_REPORTS: TopicSpec('geometry_msgs/msg/PoseWithCovarianceStamped', 'sensor',
                            f'noisy position report of the demo target with its measurement covariance R '
                            f'({COV_PLANAR}: yaw)'),
    DEMO_TRACK: TopicSpec('nav_msgs/msg/Odometry', 'estimate',
                          f'Kalman estimate of the demo target ({COV_PLANAR}: yaw, yaw rate); '
                          'child_frame_id = track id'),
    FUSION_SCORES: TopicSpec('track_msgs/msg/PairScoreArray', 'estimate',
                             'one array per instant: per pair a, b, score, combined, instants, associated; '
                             'the rule (method, combine, window, threshold) in the array'),
    FUSION_ASSOCIATIONS: TopicSpec('track_msgs/msg/PairScoreArray', 'estimate',
                                   'the associated pairs only (combined score >= threshold), same layout'),
    FUSION_FUSED: TopicSpec('track_msgs/msg/FusedTrackArray', 'estimate',
                            'covariance-intersection fusion of every associated pair of the instant: a, b, '
                            'x, y, 2x2 covariance'),
    FUSION_MARKERS: TopicSpec('visualization_msgs/msg/MarkerArray', 'estimate',
                              '2σ ellipses (flat cylinders) of the live tracks and fused pairs, pair links '
                              'coloured by score, at display_rate'),
}

# Sonar observer vs smart target (smart-target sensor-scheduling paper).
SONAR_TRUTH = '/sonar/target/truth'
SONAR_TARGET_STATUS = '/sonar/target/status'
SONAR_OBSERVER = '/sonar/observer/odom'
SONAR_ESTIMATE = '/sonar/estimate'
SONAR_PARTICLES = '/sonar/particles'
SONAR_MODE = '/sonar/mode'
SONAR_PING = '/sonar/ping'
SONAR_MARKERS = '/sonar/markers'
SONAR_CONTACTS = '/sonar/contacts'
SONAR_MODE_COMMAND = '/sonar/mode_command'

TOPICS.update({
    SONAR_CONTACTS: TopicSpec('track_msgs/msg/SonarContact', 'estimate',
                              'one sonar reading per listen or ping (a driver, or sonar_sim): mode, bearing '
                              '(REP-103 in header.frame_id), range when active, their stds'),
    SONAR_MODE_COMMAND: TopicSpec('track_msgs/msg/SonarModeCommand', 'static',
                                  "the observer's eq. 7 request for the next reading (passive|active), after every "
                                  'filter step and at start (stamp 0); latched: a driver started late gets it'),
    SONAR_TRUTH: TopicSpec('nav_msgs/msg/Odometry', 'estimate',
                           'true state of the smart target (zero covariance), stamped t_k = k·T; '
                           'child_frame_id = target id'),
    SONAR_TARGET_STATUS: TopicSpec('track_msgs/msg/SonarTargetStatus', 'estimate',
                                   'smart target after step k: target_id, mode (naive|cruise|evade), heard (a ping '
                                   'at t_{k-1} was detected), pings, detections (totals so far)'),
    SONAR_OBSERVER: TopicSpec('nav_msgs/msg/Odometry', 'estimate',
                              "the observer ship's navigation (REP-105: heading in the pose, forward speed in "
                              'child_frame_id); sonar_sim publishes it at t_k last in its step, so it also marks '
                              '"sonar step k done" for the smart target'),
    SONAR_ESTIMATE: TopicSpec('nav_msgs/msg/Odometry', 'estimate',
                              f'SS-PF/PaPF/AcPF estimate of the target with its particle covariance ({COV_PLANAR}: '
                              'yaw, yaw rate); child_frame_id = track id'),
    SONAR_PARTICLES: TopicSpec('geometry_msgs/msg/PoseArray', 'sensor',
                               'selected particles after step k (positions, identity orientation, equal weights)'),
    SONAR_MODE: TopicSpec('track_msgs/msg/SonarFilterStatus', 'estimate',
                          'the filter after each step: mode of its reading, next_mode (eq. 7 request), updated '
                          '(false: predict-only), step, ess, distance (‖P_D − Cov‖, ss-pf; -1 otherwise)'),
    SONAR_PING: TopicSpec('geometry_msgs/msg/PointStamped', 'estimate',
                          'active-ping event: the observer pinged at header.stamp from point (x, y, 0) '
                          '(published by the sonar: sonar_sim)'),
    SONAR_MARKERS: TopicSpec('visualization_msgs/msg/MarkerArray', 'estimate',
                             '2σ position ellipse of the sonar estimate (ns "sonar_estimate", id 0)'),
})

# Handheld UHF RFID reader guidance (Raptopoulos, Yioultsis & Dimitriou). A command/response
# loop: rfid_guidance publishes a command, rfid_reader (the simulated user + reader) performs it and
# answers with one step result carrying the command's seq. The protocol, its found event and the
# user's truth are typed track_msgs messages (interfaces/track_msgs/msg/Rfid*.msg: every field
# commented there, what `ros2 interface show` prints; records.rfid converts them).
# Frames: the particles live in the filter's own frame (the tag at the origin; its rotation is a free
# gauge, fixed by the first step's quadrant, see track_core/rfid/pf.py), not in ``map``; the tag estimate
# is in the user's body frame (x along the facing direction, y to the left, REP-103). The truth pose is in
# ``map`` with the tag at the origin.
RFID_FRAME_PF = 'rfid_pf'
RFID_FRAME_USER = 'rfid_user'
RFID_COMMAND = '/rfid/command'
RFID_STEP = '/rfid/step'
RFID_PHASE = '/rfid/phase'
RFID_USER_POSE = '/rfid/user/pose'
RFID_USER_STATUS = '/rfid/user/status'
RFID_PARTICLES = '/rfid/particles'
RFID_TAG_ESTIMATE = '/rfid/tag_estimate'
RFID_FOUND = '/rfid/found'

TOPICS.update({
    RFID_COMMAND: TopicSpec('track_msgs/msg/RfidCommand', 'estimate',
                            'next action for the user: seq (+1 per new command), kind (TURN, MOVE or DONE), angle '
                            '(TURN: suggested turn, rad, + = left), angle_deg, repeat (re-issued after an unusable '
                            'result), reason (why repeated / why done). Re-sent unchanged (same seq) until '
                            'answered'),
    RFID_STEP: TopicSpec('track_msgs/msg/RfidStep', 'estimate',
                         'answer to one command: seq (of the command answered), kind, dphi (MOVE: eq. 6 phase '
                         'difference, rad), turn (TURN: turn the user made and reports, rad, + = left), n_reads, '
                         'n_outliers, ok, reason (signal processing), found, duration (s of the action), dphi_std '
                         '(rad, the reader\'s own std of dphi), relocks (re-locks after lasting phase steps); an '
                         'unknown dphi, turn or dphi_std has its *_known flag false. Exactly one answer per seq; '
                         'a repeated command gets the same answer again'),
    RFID_PHASE: TopicSpec('sensor_msgs/msg/PointCloud2', 'estimate',
                          f'raw wrapped phase reads of one MOVE (height 1, one point per read; {CLOUD_XYZ} '
                          'float32 t = s since the step started, phase = wrapped rad in (0, P], rssi = dBm, '
                          'carrier_mhz = the read\'s carrier, MHz); x, y = where the simulated reader was at the '
                          'read (map, tag at the origin: the walked segment, evaluation truth like /rfid/user/pose), '
                          'z = 0; records.rfid.RfidPhase; header.stamp equals the stamp of the step result it '
                          'belongs to; frame_id map'),
    RFID_USER_POSE: TopicSpec('geometry_msgs/msg/PoseStamped', 'estimate',
                              'evaluation only: true user pose in map (tag at the origin), orientation = facing '
                              'direction (yaw), after each action'),
    RFID_USER_STATUS: TopicSpec('track_msgs/msg/RfidUserStatus', 'estimate',
                                'evaluation only: the user\'s truth after each action (frame map): seq, steps (MOVEs '
                                'walked), turns (rotations made), distance_m (walked), repeats (steps undone), '
                                'distance_to_tag_m, found, x, y, heading'),
    RFID_PARTICLES: TopicSpec('geometry_msgs/msg/PoseArray', 'sensor',
                              'particles (x, y, a) after each filter update, in frame rfid_pf (tag at the origin), '
                              'orientation = particle heading a; weights not carried'),
    RFID_TAG_ESTIMATE: TopicSpec('geometry_msgs/msg/PointStamped', 'estimate',
                                 'estimated tag position relative to the user, frame rfid_user (x forward along the '
                                 'facing direction, y left): distance · (cos b, sin b), b = suggested bearing '
                                 'including the turns made since the last MOVE'),
    RFID_FOUND: TopicSpec('track_msgs/msg/RfidFound', 'estimate',
                          'event, published once when the search ends with the tag found: seq, moves, turns, '
                          'updates, resamples, reinits'),
})

# Leader-based IDSQ acoustic/DOA sensor network. Besides the fixed topics below, every
# sensor k has four topics of its own (not in TOPICS, four per sensor; names from the helpers).
# Its readings, QoS READING_QOS (reliable, depth 256; records.idsq.IdsqReading):
#   /idsq/sensor_<k>/reading  track_msgs/msg/IdsqReading: one per step from k's front end or the
#                             simulator (vehicle_sim): amplitude; DOA direction (REP-103) and its std
# and three of the protocol, all QoS HANDOFF_QOS (reliable, transient-local, depth 4; records.idsq maps them):
#   /idsq/sensor_<k>/handoff  track_msgs/msg/IdsqHandoff: the belief handed to k (step, sender, grid,
#                             sparse cells and masses)
#   /idsq/sensor_<k>/ack      track_msgs/msg/IdsqAck: one per reply to a handoff k sent (ack or nack
#                             with the reason)
#   /idsq/sensor_<k>/revoke   track_msgs/msg/IdsqRevoke: a sender voids the handoff it sent k (chain rule)
IDSQ_TRUTH = '/idsq/vehicle/truth'
IDSQ_LAYOUT = '/idsq/layout'
IDSQ_ESTIMATE = '/idsq/estimate'
IDSQ_BELIEF = '/idsq/belief'
IDSQ_MARKERS = '/idsq/markers'
IDSQ_LEADER = '/idsq/leader'
IDSQ_ELECTION = '/idsq/election'
IDSQ_HANDOFF_REGEX = r'^/idsq/sensor_(\d+)/handoff$'
IDSQ_READING_REGEX = r'^/idsq/sensor_(\d+)/reading$'


def idsq_reading_topic(sensor: int) -> str:
    """Reading topic of sensor ``sensor`` (its front end's, or the simulator's, readings)."""
    return f'/idsq/sensor_{int(sensor)}/reading'


def idsq_handoff_topic(sensor: int) -> str:
    """Handoff topic of sensor ``sensor`` (its leader-to-be inbox)."""
    return f'/idsq/sensor_{int(sensor)}/handoff'


def idsq_ack_topic(sensor: int) -> str:
    """Ack/nack topic of sensor ``sensor`` (replies to the handoffs it sent)."""
    return f'/idsq/sensor_{int(sensor)}/ack'


def idsq_revoke_topic(sensor: int) -> str:
    """Revoke topic of sensor ``sensor`` (its senders void handoffs they sent it)."""
    return f'/idsq/sensor_{int(sensor)}/revoke'


TOPICS.update({
    IDSQ_TRUTH: TopicSpec('nav_msgs/msg/Odometry', 'static',
                          'vehicle truth at tracker step s, stamped (s + 1)·Δt (zero covariance), for evaluation '
                          '(the sensors hear only their readings); transient-local with depth 256; child_frame_id = '
                          'vehicle id'),
    IDSQ_LAYOUT: TopicSpec('sensor_msgs/msg/PointCloud2', 'static',
                           f'sensor layout, one point per sensor: {CLOUD_XYZ} 4 bytes padding and FLOAT64 id, '
                           'x_f64, y_f64 (the exact positions every sensor uses), type (0 acoustic, 1 DOA); '
                           'z = 0; published once by vehicle_sim'),
    IDSQ_ESTIMATE: TopicSpec('nav_msgs/msg/Odometry', 'estimate',
                             'MMSE estimate of the leader at step s (eq. 2) with the belief covariance as the '
                             f'x/y pose covariance ({COV_PLANAR}: yaw and the x/y velocity, 1e6); child_frame_id = '
                             'track id'),
    IDSQ_BELIEF: TopicSpec('sensor_msgs/msg/PointCloud2', 'sensor',
                           f'posterior sparse grid belief of the leader: {CLOUD_XYZ} p (mass); x, y = cell centre, '
                           'z = 0; records.idsq.IdsqBelief'),
    IDSQ_MARKERS: TopicSpec('visualization_msgs/msg/MarkerArray', 'estimate',
                            'sensors (acoustic / DOA colours), the leader highlighted, the link to the next leader '
                            'and the 2σ ellipse of the estimate'),
    IDSQ_ELECTION: TopicSpec('track_msgs/msg/IdsqReading', 'static',
                             "§5.1 start election: each sensor node relays its own step-0 reading (its amplitude) "
                             'once, transient-local (ELECTION_QOS); every sensor decides the start leader on them'),
    IDSQ_LEADER: TopicSpec('track_msgs/msg/IdsqLeaderEvent', 'estimate',
                           'one message per leader event of sensor `leader`: event (STEP|RESELECT|SELF|VOID), '
                           'step, next, previous, handoff_bytes, belief_size, spread_m2, candidates, mi_bits, '
                           'tried, failed, reason (records.idsq.IdsqLeaderEvent)'),
})

# Hybrid CEKF/PF SLAM (hybrid-cekf-pf-slam paper). Inputs, scans and GPS come from the
# Victoria Park bag (``track-dataset victoria-park``) or from ``slam_sim``; the rest from ``slam``.
#
# Vehicle inputs travel as geometry_msgs/TwistStamped (no Ackermann type in common_interfaces):
# ``twist.linear.x`` = encoder speed v_e [m/s] (the rear-left wheel of the data set),
# ``twist.angular.z`` = steering angle α [rad] (an ANGLE, not a yaw rate: the "steering angle in
# angular.z" convention of car-like robots, e.g. teb_local_planner's cmd_angle_instead_rotvel);
# every other field 0; ``header.frame_id`` = ``base_link``. The input holds from its stamp until
# the next one (zero-order hold, track_core.slam.hybrid).
# Scans: sensor_msgs/PointCloud2 (track_msgs_py.records.slam.SlamScan), one point per detected
# tree, float32 fields ``x``, ``y``, ``z`` (the detection in the laser frame, x ahead, y left; for
# the viewers), ``range`` [m, to the trunk surface as measured], ``bearing`` [rad,
# eq. 5 convention: 0 = vehicle's right, π/2 ahead, π left], ``diameter`` [m] (0 for point
# landmarks); ``slam_sim`` adds ``landmark`` (true landmark index, evaluation only);
# ``header.frame_id`` = ``laser``. An empty scan (width 0) is allowed.
FRAME_BASE = 'base_link'   # the vehicle (inputs)
FRAME_LASER = 'laser'      # the laser; the SLAM state (x, y, φ) is the pose of this frame in map
FRAME_LASER_TRUTH = 'laser_truth'  # slam_sim: the true laser pose (its own frame: laser is the estimate's)
FRAME_GPS = 'gps'          # Victoria Park GPS: local east/north frame, rotated and shifted from map

SLAM_INPUTS = '/slam/inputs'
SLAM_SCAN = '/slam/scan'
SLAM_GPS = '/slam/gps'
SLAM_TRUTH = '/slam/truth'
SLAM_POSE = '/slam/pose'
SLAM_MAP = '/slam/map'
SLAM_MODE = '/slam/mode'
SLAM_EVENTS = '/slam/events'
SLAM_PARTICLES = '/slam/particles'

TOPICS.update({
    # Inputs and scans are 'estimate' (reliable), not 'sensor': SLAM integrates every input and a
    # dropped input is a dead-reckoning error that no later message repairs.
    SLAM_INPUTS: TopicSpec('geometry_msgs/msg/TwistStamped', 'estimate',
                           'vehicle inputs: twist.linear.x = encoder speed [m/s], twist.angular.z = steering '
                           'ANGLE [rad] (not a rate); frame base_link'),
    SLAM_SCAN: TopicSpec('sensor_msgs/msg/PointCloud2', 'estimate',
                         f'one laser scan of tree detections: {CLOUD_XYZ} float32 range [m], bearing [rad, 0 = '
                         'right, π/2 ahead], diameter [m] (slam_sim: + landmark id); x, y, z = the detection in the '
                         'laser frame (x ahead, y left: x = r sin b, y = -r cos b, z = 0); records.slam.SlamScan; '
                         'frame laser'),
    SLAM_GPS: TopicSpec('geometry_msgs/msg/PointStamped', 'estimate',
                        'GPS fix (x, y) in the gps frame (east/north, rotated and shifted from map); evaluation '
                        'only, has jumps'),
    SLAM_TRUTH: TopicSpec('nav_msgs/msg/Odometry', 'estimate',
                          'slam_sim: true laser pose (x, y, yaw φ) in map, zero covariance (twist not estimated, '
                          '1e6); child_frame_id laser_truth (also on /tf); evaluation only'),
    SLAM_POSE: TopicSpec('nav_msgs/msg/Odometry', 'estimate',
                         'SLAM laser pose after each scan: position x, y, orientation yaw φ; pose.covariance '
                         f'x/y/yaw entries (0, 1, 5 of 6) from the filter ({COV_PLANAR}: the twist x/y and yaw '
                         'rate); child_frame_id laser'),
    SLAM_MAP: TopicSpec('visualization_msgs/msg/MarkerArray', 'static',
                        'landmark map at a modest rate: DELETEALL, one SPHERE_LIST of the means (ns slam_landmarks, '
                        'id 0) and one 2σ ellipse per landmark (ns slam_ellipses, id = landmark index)'),
    SLAM_MODE: TopicSpec('track_msgs/msg/SlamStatus', 'estimate',
                         'after each scan: mode CEKF|PF, scans, inputs, landmarks, pf_switches, pf_scans, '
                         'dropped_observations, refused_messages, bad_inputs, bad_scans'),
    SLAM_EVENTS: TopicSpec('track_msgs/msg/SlamEvent', 'estimate',
                           'one message per mode switch: event TO_PF|TO_CEKF|PF_TIMEOUT, pf_scans, the pose x, y, '
                           'yaw after its scan (in header.frame_id)'),
    SLAM_PARTICLES: TopicSpec('geometry_msgs/msg/PoseArray', 'sensor',
                              'PF mode only: the particle cloud after each scan (global frame, heading in the '
                              'orientation; at most max_particles_published); an empty array on leaving PF'),
})

# SLAM on any robot through standard inputs and REP-105 outputs (track_msgs_py.records.landmarks): the
# robot's driver publishes odom (and odom → base_link on /tf), a laser driver scan; landmark_extractor
# turns scans into landmark detections (any other front end may publish them); slam publishes map → odom.
FRAME_ODOM = 'odom'        # REP-105: the robot's continuous odometry frame (its driver owns odom → base_link)
SLAM_ODOM = '/odom'
SLAM_LASER_SCAN = '/scan'
SLAM_LANDMARKS = '/slam/landmarks'
SLAM_LANDMARK_MAP = '/slam/landmark_map'
TOPICS.update({
    SLAM_ODOM: TopicSpec('nav_msgs/msg/Odometry', 'estimate',
                         "the robot driver's odometry (REP-105): pose of base_link in odom, twist in base_link "
                         '(v = linear.x, yaw rate = angular.z) with its covariance'),
    SLAM_LASER_SCAN: TopicSpec('sensor_msgs/msg/LaserScan', 'sensor',
                               'a planar laser scan (REP-117: +inf = no return), frame laser; landmark_extractor '
                               'reads it'),
    SLAM_LANDMARKS: TopicSpec('track_msgs/msg/LandmarkDetectionArray', 'estimate',
                              'point landmarks of one instant in a sensor frame: range [m, to the centre], bearing '
                              '[rad, REP-103], diameter [m], 3x3 covariance each; from landmark_extractor or any '
                              'front end'),
    SLAM_LANDMARK_MAP: TopicSpec('track_msgs/msg/LandmarkMap', 'static',
                                 'the SLAM landmark map (id, x, y, 2x2 covariance per landmark) in map, beside '
                                 '/slam/map'),
})

# Recognised maritime picture on real AIS ships. Each ``ais_source`` node is one
# simulated surveillance source with a topic prefix (``/ais/radar``, ``/ais/patrol``):
#   <prefix>/reports  track_msgs/TrackArray, one message per report instant with every ship reported
#                     at it, frame map; the local track id in tracks[].id (e.g. "r017"). The fusion
#                     node lists such topics in ``track_array_topics`` (track id = "<topic>/<local id>").
#   <prefix>/markers  visualization_msgs/MarkerArray: the same instant drawn (2σ disc + id label per ship).
#   <prefix>/truth    diagnostic_msgs/DiagnosticArray (static QoS), evaluation only: one status per
#                     local track, name = the fusion track id "<prefix>/reports/<local id>", value mmsi.
# One topic per source, not one per ship: a topic per ship (~90 per source) makes every executor
# wait cost ~100 ms and the lock-step clock unusable.
# ``track_frame_id`` ("<frame>#<local id>") is the fusion node's older many-tracks input
# (``pose_track_topics``) only: such a frame_id names no frame, so RViz, Foxglove and
# ``track_nodes.bag.frames`` cannot place it; sources of many tracks publish a TrackArray instead.
TRACK_FRAME_SEP = '#'
AIS_RADAR = '/ais/radar'
AIS_PATROL = '/ais/patrol'


def track_frame_id(frame: str, track_id: str) -> str:
    """``header.frame_id`` of a report that carries its local track id: ``"<frame>#<track id>"``."""
    return f'{frame}{TRACK_FRAME_SEP}{track_id}'


def split_track_frame_id(frame_id: str) -> tuple[str, str]:
    """``"map#r017"`` → ``("map", "r017")``; the id is ``""`` when there is none."""
    frame, _, track_id = frame_id.partition(TRACK_FRAME_SEP)
    return frame, track_id


def ais_reports_topic(prefix: str) -> str:
    return f'{prefix.rstrip("/")}/reports'


def ais_truth_topic(prefix: str) -> str:
    return f'{prefix.rstrip("/")}/truth'


def ais_markers_topic(prefix: str) -> str:
    return f'{prefix.rstrip("/")}/markers'


for _prefix, _what in ((AIS_RADAR, 'coastal radar'), (AIS_PATROL, 'patrol')):
    TOPICS.update({
        ais_reports_topic(_prefix): TopicSpec(
            'track_msgs/msg/TrackArray', 'estimate',
            f'{_what} reports of real AIS ships, one array per report instant with every ship reported at it '
            '(frame map): tracks[].id = the local track id (no MMSI), position + 2σ-ellipse covariance, velocity '
            'not estimated'),
        ais_markers_topic(_prefix): TopicSpec(
            'visualization_msgs/msg/MarkerArray', 'estimate',
            f'the {_what} reports of one instant drawn: a 2σ disc (ns <id_prefix>) and an id label (ns '
            '<id_prefix>_ids) per ship, lifetime two report periods'),
        ais_truth_topic(_prefix): TopicSpec(
            'diagnostic_msgs/msg/DiagnosticArray', 'static',
            f'evaluation only: the {_what}\'s local tracks, one status per track, name "<reports topic>/<local '
            'id>" (the fusion track id), values mmsi, reports'),
    })
del _prefix, _what

# Live AIS (ais_nmea_source) and the run's one map datum (track_msgs_py.ais, track_core.ais.datum).
AIS_NMEA = '/ais/nmea'
AIS_NMEA_TRACKS = f'{AIS_NMEA}/tracks'
AIS_NMEA_SHIPS = f'{AIS_NMEA}/ships'
MAP_DATUM = '/map_datum'
TOPICS.update({
    AIS_NMEA_TRACKS: TopicSpec('track_msgs/msg/TrackArray', 'estimate',
                               'live AIS: one array per decoded position report (frame map), one track, id = the '
                               'MMSI; covariance from the position-accuracy flag, velocity from SOG/COG or not '
                               'estimated'),
    AIS_NMEA_SHIPS: TopicSpec('diagnostic_msgs/msg/DiagnosticArray', 'static',
                              'live AIS: static data of every ship heard, one status per MMSI (name = MMSI, '
                              'values name, ship_type, callsign, reports)'),
    MAP_DATUM: TopicSpec('sensor_msgs/msg/NavSatFix', 'static',
                         'the origin of map on WGS-84 (frame_id map): one per run, latched; map is the transverse '
                         'Mercator about it (track_core.ais.datum)'),
})

# Maritime scenario's coastal radar: a report_source with prefix /radar (config/maritime.yaml) that reports
# the decoy (ship 0) and publishes its truth (track_nodes.report.maritime reads both).
MARITIME_RADAR_TRACK = '/radar/t0'
MARITIME_RADAR_TRUTH = '/radar/truth'
TOPICS.update({
    MARITIME_RADAR_TRACK: TopicSpec('geometry_msgs/msg/PoseWithCovarianceStamped', 'estimate',
                                    f'maritime: the coastal radar\'s track of the decoy, position + 2σ ellipse '
                                    f'({COV_PLANAR}: yaw)'),
    MARITIME_RADAR_TRUTH: TopicSpec('nav_msgs/msg/Odometry', 'estimate',
                                    'maritime: the decoy\'s true state (zero covariance), child_frame_id t0; '
                                    'evaluation only'),
})

# Display twins (track_msgs_py.display.display_twin): Foxglove's 3D panel draws neither Odometry nor
# PointStamped, so each topic of DISPLAY_TWINS (those the shipped layouts draw: tools/displays.py)
# has a drawable twin on <topic>/pose, published beside it by the same node with the same QoS
# (TrackNode.create_publisher). Names as they resolve in the root namespace, like every name here.
TWIN_TYPES = {'nav_msgs/msg/Odometry': 'geometry_msgs/msg/PoseWithCovarianceStamped',
              'geometry_msgs/msg/PointStamped': 'geometry_msgs/msg/PoseStamped'}
DISPLAY_TWIN_SUFFIX = '/pose'
DISPLAY_TWINS = frozenset({SONAR_ESTIMATE, IDSQ_ESTIMATE, SONAR_TRUTH, SONAR_OBSERVER, SONAR_PING, MARITIME_RADAR_TRUTH,
                           SLAM_POSE, SLAM_TRUTH, RFID_TAG_ESTIMATE})


def display_twin(topic: str) -> str:
    """The topic of ``topic``'s drawable twin: ``/sonar/estimate`` → ``/sonar/estimate/pose``."""
    return topic.rstrip('/') + DISPLAY_TWIN_SUFFIX


for _topic in sorted(DISPLAY_TWINS):
    _type = TOPICS[_topic].msgtype
    TOPICS[display_twin(_topic)] = TopicSpec(
        TWIN_TYPES[_type], TOPICS[_topic].qos,
        f'display twin of {_topic} for Foxglove\'s 3D panel: same header, '
        + ('pose and covariance (the 2σ ellipse)' if _type.endswith('Odometry') else 'the point, identity orientation'))
del _topic, _type
