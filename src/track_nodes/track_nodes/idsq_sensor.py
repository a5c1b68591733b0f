"""Shared logic of ``acoustic_sensor`` and ``doa_sensor``: one node per sensor of the IDSQ network.

Each instance is one sensor (parameters ``id``, ``position``, ``type``) and reads everything
else about the network from the layout that ``vehicle_sim`` publishes (transient-local
``/idsq/layout``, read by ``track_msgs_py.convert.pointcloud2_to_layout``): the other sensors'
positions and types, hence its neighbour list (§5.1 rule, ``track_core.idsq.SensorLayout``). The
``id``/``position``/``type`` parameters must agree with the layout entry of ``id`` (checked when
the layout arrives; on a mismatch the node logs one error line and stays passive).

Protocol (Table 1 of the paper, one leader at a time, all over standard messages):

- A sensor sleeps until a handoff arrives on its own topic ``/idsq/sensor_<id>/handoff``
  (``std_msgs/UInt8MultiArray``; ``data`` = the core's ``encode_handoff`` bytes: header with step,
  sender = previous leader, receiver, grid, then the sparse belief; ``layout.dim[0]`` is labelled
  ``idsq_handoff_v1``: ``track_msgs_py.convert.handoff_to_uint8_array``). It validates it with
  ``receive_handoff`` (NaN/negative/unnormalised mass, wrong grid, wrong receiver, bad indices)
  and replies on the sender's ``/idsq/sensor_<j>/ack`` (``diagnostic_msgs/DiagnosticArray``, one
  status ``sensor_<id>``: level OK + ``result=ack``, or level WARN + ``result=nack`` and the
  reason as message; values ``step``, ``sender``, ``receiver``; the core's ``peek_header`` finds
  whom to refuse when the bytes are unusable). A refused handoff is logged with one warning line.
- The accepted belief p(x⁽ᵗ⁾|z̄⁽ᵗ⁾) is held until the vehicle truth of step t + 1 is known, then
  the sensor leads step t + 1 with ``track_core.idsq.leader_step``: diffuse, sense (its own
  measurement simulated from the truth with its noise, see *Randomness*), update, MI of each
  neighbour except the previous leader (triplet rule), choose the next leader, encode the
  handoff. It publishes ``/idsq/estimate`` (Odometry with the belief covariance),
  ``/idsq/belief`` (PointCloud2 x, y, p), ``/idsq/markers`` and ``/idsq/leader``
  (DiagnosticArray), then sends the handoff to the chosen neighbour.
- Start (§5.1): when the truth of step 0 arrives, every sensor computes the amplitude reading of
  every sensor (each reading is a deterministic function of the seed, the sensor id and the
  step; the core's ``simulation.start_leader_at``); the winner, the acoustic sensor with the highest reading,
  leads step 0 from the uniform belief. Every sensor reaches the same answer without messages;
  this stands in for the election the paper does not describe.
- Leader failure (beyond the paper): a handoff not acknowledged within ``ack_timeout`` seconds of
  the steady (wall) clock, or refused with a nack, is re-sent to the next candidate in
  decreasing MI order; after the candidates, the previous leader (if a neighbour), and finally
  the leader itself, which then leads the next step too, so the track never stops. A neighbour
  that timed out is tried last by this sensor afterwards, until it acknowledges again. The
  timeout is on the steady clock because an ack only depends on message latency, not on
  simulated time; with ``--processes`` the /clock runs regardless of CPU load, and a sim-time
  timeout would re-select spuriously. A sensor may lead again before the ack of its previous
  handoff is processed (a leader ring under load), so outstanding handoffs are kept per step.
  Limitation: an ack arriving after its timeout is ignored (logged), so a receiver that was slow
  rather than dead would lead a forked track; the default timeout (2 s of wall time) is meant to
  be far above an ack round trip (one message each way and one callback).
- Several sources (``truth_topics``, beyond the paper): every listed topic carries the truth of one
  or more sources (Odometry, one ``child_frame_id`` per source); a step is sensed once each
  topic has delivered that step, and each sensor hears the loudest source at its own position,
  i.e. the nearest one (every source has the same amplitude A, and A/r falls with range). The
  network therefore tracks whatever is loudest in its field. The default, ``[/idsq/vehicle/truth]``,
  is the paper's single vehicle. The default topic is subscribed with the transient-local
  ``TRUTH_QOS``; any other topic reliable and volatile (depth 256), so it matches an ordinary
  reliable publisher such as ``smart_target``'s truth.
- Asleep, a sensor only buffers the truth messages (its microphone, so to speak: a dict insert
  per step); with the start rule this is its only work until a handoff arrives.
- Time: step s of the vehicle truth is stamped (s + 1)·Δt (``FixedRateSteps`` ticks first one
  period after the origin), and every leader output of step s carries that stamp. A leader
  that falls behind the clock uses the buffered truth, so the track does not depend on timing.

Randomness: the measurement of sensor k at step s uses one standard normal drawn from
``SeedSequence(seed, spawn_key=(3, k, s))`` (``measurement_normal``), and the ``random``
selection baseline a Generator from ``spawn_key=(4, k, s)``; nothing depends on which process a
sensor runs in or on callback order, so one process or one process per sensor give the same
track. (The core experiments draw one (T, K) matrix per run instead; keys 0-2 are theirs.)

QoS: handoff and ack topics are reliable and transient-local (depth 4), so a handoff published
while discovery between two processes is still settling is delivered when they match. The
truth is reliable and transient-local with depth 256: a busy leader loses no step, and a sensor
whose reader matches vehicle_sim's writer only after step 0 was published (seen with
``--processes``) still gets step 0, which every sensor needs for the start rule.

Cost of many nodes in one process: rclpy rebuilds its wait set over every entity of every node
at each wait, and the default QoS-event handlers of each publisher and subscription are most of
those entities (26 nodes of 12 publishers and 5 subscriptions each: 68 ms per wait with them,
6.5 ms without, measured on a 2-core machine). A sensor
therefore creates its endpoints without the default event handlers (no "incompatible QoS"
warning on them), and it does not follow /clock: every stamp it publishes is the time of the
step it belongs to, taken from the truth, and its only timer runs on the steady clock, so it
needs no ROS clock at all. It drops the /clock subscription that ``use_sim_time`` made; otherwise
each 0.05 s tick of the launcher's lock-step clock would wake every sensor.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import Point
from nav_msgs.msg import Odometry
from rclpy.clock import Clock, ClockType
from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import ColorRGBA, Header, UInt8MultiArray
from visualization_msgs.msg import Marker, MarkerArray

from track_core.idsq import (
    GridSpec,
    Handoff,
    SensorLayout,
    SimNoise,
    SparseBelief,
    TrackerParams,
    encode_handoff,
    leader_step,
    receive_handoff,
    simulate_measurement,
    uniform_belief,
)
from track_core.idsq.handoff import peek_header
from track_core.idsq.models import DEG, loudest_source
from track_core.idsq.network import handoff_targets as core_handoff_targets
from track_core.idsq.prediction import PREDICTIONS
from track_core.idsq.simulation import start_leader_at
from track_core.idsq.tracker import SELECTIONS
from track_msgs_py.convert import (
    DIAG_OK,
    DIAG_WARN,
    UNUSED_VARIANCE,
    covariance_ellipse_marker,
    cv_state_to_odometry,
    diagnostic_array,
    diagnostic_status,
    handoff_to_uint8_array,
    odometry_to_cv_state,
    pointcloud2_to_layout,
    sec_to_stamp,
    stamp_to_sec,
    table_to_pointcloud2,
    uint8_array_to_handoff,
)
from track_msgs_py.qos import ESTIMATE_QOS, HANDOFF_QOS, SENSOR_QOS, STATIC_QOS, TRUTH_QOS
from track_msgs_py.topics import (
    CLOCK,
    FRAME_MAP,
    IDSQ_BELIEF,
    IDSQ_ESTIMATE,
    IDSQ_LAYOUT,
    IDSQ_LEADER,
    IDSQ_MARKERS,
    IDSQ_TRUTH,
    KNOWN_FRAMES,
    idsq_ack_topic,
    idsq_handoff_topic,
)
from track_msgs_py.validate import odometry_problem
from track_nodes.node_util import Param, ParameterError, declare_params, run_node

SENSOR_TYPES = ('acoustic', 'doa')
MEASUREMENT_KEY, SELECTION_KEY = 3, 4
MAX_TRUTH = 4096  # buffered truth steps per sensor (the §5.1 track has 72)
SOURCE_TRUTH_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=256, reliability=ReliabilityPolicy.RELIABLE)


# --- time, randomness, start -------------------------------------------------------------------

def stamp_of_step(step: int, dt: float) -> float:
    """Node time [s] of tracker step ``step``: (step + 1)·Δt (see the module docstring)."""
    return (int(step) + 1) * dt


def step_of_stamp(t: float, dt: float) -> int | None:
    """Tracker step of a truth stamp, or ``None`` when ``t`` is not (s + 1)·Δt for an s >= 0."""
    s = round(t / dt) - 1
    return s if s >= 0 and abs(stamp_of_step(s, dt) - t) <= 1e-6 else None


def measurement_normal(seed: int, sensor: int, step: int) -> float:
    """The standard normal of sensor ``sensor``'s measurement at ``step`` (independent of process layout)."""
    ss = np.random.SeedSequence(int(seed), spawn_key=(MEASUREMENT_KEY, int(sensor), int(step)))
    return float(np.random.default_rng(ss).standard_normal())


def selection_rng(seed: int, sensor: int, step: int) -> np.random.Generator:
    """Generator of the ``random`` selection baseline for ``sensor`` leading ``step``."""
    return np.random.default_rng(np.random.SeedSequence(int(seed), spawn_key=(SELECTION_KEY, int(sensor), int(step))))


loudest = loudest_source  # (sources (2,) or (M, 2), sensor (2,)) → the nearest source: what the sensor hears


def start_leader_of(layout: SensorLayout, truth0: np.ndarray, noise: SimNoise, seed: int) -> int:
    """§5.1 start as every sensor computes it: the core's ``start_leader_at`` on the step-0 readings drawn
    with ``measurement_normal``. ``truth0``: one source (2,) or several (M, 2), each sensor hears its loudest."""
    normals = [measurement_normal(seed, k, 0) for k in range(layout.n)]  # one seeded draw per sensor
    return start_leader_at(layout, truth0, noise, np.array(normals))


def handoff_targets(layout: SensorLayout, k: int) -> set[int]:
    """Every sensor ``k`` may hand off to (the core's ``network.handoff_targets``), as a set."""
    return set(core_handoff_targets(layout, k).tolist())


def handoff_order(cands: np.ndarray, scores: np.ndarray, neighbours: np.ndarray, previous: int | None,
                  me: int, first: int | None = None, last: set[int] | frozenset = frozenset()) -> list[int]:
    """Who to try, in order: ``first`` (the core's choice), the other candidates by decreasing score,
    those in ``last`` (suspected dead) after them, then the previous leader if it is a neighbour,
    and ``me`` at the end (the leader keeps the track)."""
    ranked = [int(c) for c in np.asarray(cands)[np.argsort(-np.asarray(scores, dtype=float), kind='stable')]]
    if first is not None and first in ranked:
        ranked.remove(first)
        ranked.insert(0, first)
    ranked = [c for c in ranked if c not in last] + [c for c in ranked if c in last]
    if previous is not None and previous != me and previous in set(np.asarray(neighbours).tolist()) \
            and previous not in ranked:
        ranked.append(int(previous))
    return [*ranked, me]


# --- messages --------------------------------------------------------------------------------------

def sensor_markers(t: float, layout: SensorLayout, leader: int, nxt: int | None, mean: np.ndarray,
                   cov: np.ndarray) -> MarkerArray:
    """Sensors (acoustic blue, DOA green), the leader (red), the link to the next leader, the 2σ ellipse."""
    header = Header(stamp=sec_to_stamp(t), frame_id=FRAME_MAP)
    pts = [Point(x=x, y=y) for x, y in layout.positions.tolist()]
    colours = [ColorRGBA(r=0.1, g=0.8, b=0.2, a=1.0) if d else ColorRGBA(r=0.2, g=0.4, b=1.0, a=1.0)
               for d in layout.is_doa.tolist()]
    sensors = Marker(header=header, ns='idsq_sensors', id=0, type=Marker.SPHERE_LIST, action=Marker.ADD,
                     points=pts, colors=colours)
    sensors.scale.x = sensors.scale.y = sensors.scale.z = 4.0
    lead = Marker(header=header, ns='idsq_leader', id=0, type=Marker.SPHERE, action=Marker.ADD,
                  color=ColorRGBA(r=1.0, g=0.1, b=0.1, a=0.9))
    lead.pose.position = Point(x=float(layout.positions[leader, 0]), y=float(layout.positions[leader, 1]))
    lead.scale.x = lead.scale.y = lead.scale.z = 8.0
    sensors.pose.orientation.w = lead.pose.orientation.w = 1.0
    markers = [sensors, lead]
    if nxt is not None and nxt != leader:
        link = Marker(header=header, ns='idsq_next', id=0, type=Marker.ARROW, action=Marker.ADD,
                      points=[pts[leader], pts[nxt]], color=ColorRGBA(r=1.0, g=0.6, b=0.0, a=1.0))
        link.pose.orientation.w = 1.0
        link.scale.x, link.scale.y, link.scale.z = 1.0, 3.0, 3.0
        markers.append(link)
    markers.append(covariance_ellipse_marker(t, mean, cov, FRAME_MAP, ns='idsq_estimate', line_width=1.0))
    return MarkerArray(markers=markers)


# --- the node ----------------------------------------------------------------------------------------

def sensor_params(sensor_type: str) -> tuple[Param, ...]:
    tp, noise = TrackerParams(), SimNoise()
    return (
        Param('id', 0, 'index of this sensor in the layout published by vehicle_sim', 0, 65535),
        Param('position', [0.0, 0.0], 'sensor position [x, y] in map; must equal its layout entry [m]'),
        Param('type', sensor_type, f'sensor type; this executable runs {sensor_type} sensors', choices=SENSOR_TYPES),
        Param('seed', 0, 'measurement-noise seed (one draw per (seed, sensor id, step))', 0, 2**31 - 1),
        Param('width', 150.0, 'field width (x) covered by the grid (§5.1: 150 m) [m]', 1.0, 1e5),
        Param('height', 250.0, 'field height (y) covered by the grid (§5.1: 250 m) [m]', 1.0, 1e5),
        Param('cell', 5.0, 'grid cell size (§5.1: 5 m) [m]', 0.1, 1e3),
        Param('dt', tp.dt, 'tracker step Δt; the truth of step s is stamped (s + 1)·Δt (§5.1: 0.5 s) [s]', 1e-3, 60.0),
        Param('v_max', tp.v_max, 'maximum vehicle speed of the diffusion disk (§5.1: 15 m/s) [m/s]', 1e-3, 1e3),
        Param('a_lo', tp.a_lo, 'lower bound of the source amplitude prior of eq. 6 (§5.1: 0)', 0.0, 1e6),
        Param('a_hi', tp.a_hi, 'upper bound of the source amplitude prior of eq. 6 (§5.1: 80)', 1e-6, 1e6),
        Param('sigma_k', tp.sigma_a, 'amplitude noise σ_k of the tracker model, eq. 6 (§5.1: 0.1)', 1e-6, 1e3),
        Param('r_near', tp.r_near, 'Fig. 6 DOA model: σ grows below this range (§5.1: 20 m) [m]', 0.0, 1e5),
        Param('r_far', tp.r_far, 'Fig. 6 DOA model: σ grows beyond this range (§5.1: 100 m) [m]', 1e-3, 1e5),
        Param('sigma_doa_deg', tp.sigma_doa / DEG, 'Fig. 6 DOA σ inside [r_near, r_far] [deg]', 1e-3, 180.0),
        Param('amplitude', noise.amplitude, 'simulated source amplitude A (§5.1: 40)', 1e-6, 1e6),
        Param('noise_sigma_a', noise.sigma_a, 'simulated amplitude noise std (§5.1: 0.05)', 0.0, 1e3),
        Param('noise_sigma_doa_deg', noise.sigma_doa / DEG, 'simulated DOA noise std (§5.1: 3°) [deg]', 0.0, 180.0),
        Param('comm_range', 40.0, 'radio range of the §5.1 neighbour rule (else the two nearest) [m]', 1e-3, 1e6),
        Param('selection', 'mi', 'next-leader rule: mi (Table 1), nearest or random (baselines)', choices=SELECTIONS),
        Param('prediction', 'diffusion', 'belief prediction: diffusion (§2.1), or drift / bank (velocity-aware, '
              'track_core.idsq.prediction)', choices=PREDICTIONS),
        Param('ack_timeout', 2.0, 'steady-clock wait for an ack before re-selecting [s]', 1e-3, 600.0),
        Param('track_id', 'idsq_track', 'child_frame_id of the estimate'),
        Param('truth_topics', [IDSQ_TRUTH], 'Odometry truth topics of the sources; each sensor senses the loudest '
              '(nearest) source (module docstring)'),
    )


@dataclass
class _Pending:
    """A belief p(x⁽ᵗ⁻¹⁾|z̄) waiting for the truth of ``step`` = t, to be led by this sensor."""

    belief: SparseBelief
    step: int
    previous: int | None


@dataclass
class _Outgoing:
    """The posterior of ``step`` being handed off: who is tried now and who is left."""

    step: int
    belief: SparseBelief
    order: list[int]
    receiver: int | None = None
    timer: object = None
    tried: list[int] = field(default_factory=list)


class IdsqSensorNode(Node):
    """One sensor of the IDSQ network; ``AcousticSensorNode`` / ``DoaSensorNode`` fix the type."""

    DEFAULT_NAME = 'idsq_sensor'
    SENSOR_TYPE = 'acoustic'

    def __init__(self, *, node_name: str | None = None, context=None, parameter_overrides=None,
                 cli_args=None) -> None:
        super().__init__(node_name or self.DEFAULT_NAME, context=context, parameter_overrides=parameter_overrides,
                         cli_args=cli_args)
        self.p = p = declare_params(self, sensor_params(self.SENSOR_TYPE))
        if p.type != self.SENSOR_TYPE:
            raise ParameterError(f'parameter type={p.type!r} is invalid for {self.DEFAULT_NAME}: allowed '
                                 f'{self.SENSOR_TYPE!r} (run {p.type}_sensor for a {p.type} sensor)')
        pos = np.asarray(p.position, dtype=float)
        if pos.shape != (2,) or not np.all(np.isfinite(pos)):
            raise ParameterError(f'parameter position={list(p.position)!r} is invalid: allowed 2 finite numbers')
        self.id, self.position, self.is_doa = int(p.id), pos, p.type == 'doa'
        self.tp = TrackerParams(v_max=p.v_max, dt=p.dt, a_lo=p.a_lo, a_hi=p.a_hi, sigma_a=p.sigma_k,
                                r_near=p.r_near, r_far=p.r_far, sigma_doa=p.sigma_doa_deg * DEG,
                                prediction=p.prediction)
        self.noise = SimNoise(amplitude=p.amplitude, sigma_a=p.noise_sigma_a, sigma_doa=p.noise_sigma_doa_deg * DEG)
        self.grid = GridSpec.for_field(p.width, p.height, p.cell)
        self.layout: SensorLayout | None = None
        self.disabled = False
        self.truth: dict[int, np.ndarray] = {}  # step → (M, 2) source positions, once every topic has it
        self.truth_topics = [t for t in p.truth_topics if t]
        if not self.truth_topics:
            raise ParameterError('parameter truth_topics is empty: allowed one or more Odometry topics')
        self._sources: dict[int, dict[tuple[str, str], np.ndarray]] = {}  # step → (topic, child) → xy
        self.inbox: list[bytes] = []
        self.pending: _Pending | None = None
        self.outgoing: dict[int, _Outgoing] = {}  # step → handoff awaiting its ack (several if acks lag)
        self.start_checked = False
        self.last_led = -1
        self.led: list[int] = []  # steps this sensor led
        self.suspects: set[int] = set()
        self.refused = self.timeouts = self.nacks = 0
        self._steady = Clock(clock_type=ClockType.STEADY_TIME)
        for sub in [s for s in self.subscriptions if s.topic_name == CLOCK]:
            self.destroy_subscription(sub)  # no ROS clock needed (module docstring)
        self.handoff_pubs: dict[int, object] = {}
        self.ack_pubs: dict[int, object] = {}
        self.pub_est = self._pub(Odometry, IDSQ_ESTIMATE, ESTIMATE_QOS)
        self.pub_belief = self._pub(PointCloud2, IDSQ_BELIEF, SENSOR_QOS)
        self.pub_markers = self._pub(MarkerArray, IDSQ_MARKERS, ESTIMATE_QOS)
        self.pub_leader = self._pub(DiagnosticArray, IDSQ_LEADER, ESTIMATE_QOS)
        self._sub(PointCloud2, IDSQ_LAYOUT, self._on_layout, STATIC_QOS)
        for topic in self.truth_topics:
            self._sub(Odometry, topic, lambda m, topic=topic: self._on_truth(m, topic),
                      TRUTH_QOS if topic == IDSQ_TRUTH else SOURCE_TRUTH_QOS)
        self._sub(UInt8MultiArray, idsq_handoff_topic(self.id), self._on_handoff, HANDOFF_QOS)
        self._sub(DiagnosticArray, idsq_ack_topic(self.id), self._on_ack, HANDOFF_QOS)

    def _pub(self, cls, topic: str, qos: QoSProfile):
        return self.create_publisher(cls, topic, qos,
                                     event_callbacks=PublisherEventCallbacks(use_default_callbacks=False))

    def _sub(self, cls, topic: str, callback, qos: QoSProfile):
        return self.create_subscription(cls, topic, callback, qos,
                                        event_callbacks=SubscriptionEventCallbacks(use_default_callbacks=False))

    # -- inputs -------------------------------------------------------------------------------------
    def _on_layout(self, msg: PointCloud2) -> None:
        if self.layout is not None or self.disabled:
            return
        try:
            layout = pointcloud2_to_layout(msg, self.p.comm_range)
        except ValueError as exc:
            self.get_logger().error(f'{IDSQ_LAYOUT}: unusable layout: {exc}')
            return
        why = None
        if self.id >= layout.n:
            why = f'id={self.id} is not in the layout of {layout.n} sensors'
        elif not np.allclose(layout.positions[self.id], self.position, rtol=0.0, atol=1e-6):
            why = (f'position={self.position.tolist()} differs from the layout entry '
                   f'{layout.positions[self.id].tolist()}')
        elif bool(layout.is_doa[self.id]) != self.is_doa:
            why = f'type={self.p.type} differs from the layout entry (DOA={bool(layout.is_doa[self.id])})'
        if why is not None:
            self.disabled = True
            self.get_logger().error(f'{IDSQ_LAYOUT}: sensor {self.id}: {why}; staying passive')
            return
        self.layout = layout
        targets = [handoff_targets(layout, j) for j in range(layout.n)]  # K sensors
        for k in targets[self.id]:
            self._handoff_pub(k)
        for j in range(layout.n):  # whom I may have to answer
            if self.id in targets[j]:
                self._ack_pub(j)
        self._advance()

    def _handoff_pub(self, k: int):
        if k not in self.handoff_pubs:  # normally made at layout time; transient-local covers a late one
            self.handoff_pubs[k] = self._pub(UInt8MultiArray, idsq_handoff_topic(k), HANDOFF_QOS)
        return self.handoff_pubs[k]

    def _ack_pub(self, k: int):
        if k not in self.ack_pubs:
            self.ack_pubs[k] = self._pub(DiagnosticArray, idsq_ack_topic(k), HANDOFF_QOS)
        return self.ack_pubs[k]

    def _on_truth(self, msg: Odometry, topic: str = IDSQ_TRUTH) -> None:
        reason = odometry_problem(msg, KNOWN_FRAMES)
        t = stamp_to_sec(msg.header.stamp)
        step = step_of_stamp(t, self.p.dt)
        if reason is None and step is None:
            reason = f'stamp {t:.9f} s is not (s + 1)·dt for dt={self.p.dt} s'
        if reason is not None:
            self.get_logger().warning(f'{topic}: dropped truth: {reason}')
            return
        _, x, _ = odometry_to_cv_state(msg)
        if step in self.truth:
            return  # this step was complete already: a source repeating it does not change it
        got = self._sources.setdefault(step, {})
        got[(topic, msg.child_frame_id)] = x[[0, 2]]
        if {tp for tp, _ in got} >= set(self.truth_topics):  # every topic has delivered this step
            del self._sources[step]
            self.truth[step] = np.array([got[k] for k in sorted(got)])
            if len(self.truth) > MAX_TRUTH:
                del self.truth[min(self.truth)]
        while len(self._sources) > MAX_TRUTH:
            del self._sources[min(self._sources)]
        self._advance()

    def _on_handoff(self, msg: UInt8MultiArray) -> None:
        self.inbox.append(uint8_array_to_handoff(msg))
        self._advance()

    def _on_ack(self, msg: DiagnosticArray) -> None:
        for st in msg.status:
            v = {kv.key: kv.value for kv in st.values}
            try:
                step, sender, receiver, result = int(v['step']), int(v['sender']), int(v['receiver']), v['result']
            except (KeyError, ValueError):
                self.get_logger().warning(f'{idsq_ack_topic(self.id)}: malformed reply {st.name!r} ignored')
                continue
            out = self.outgoing.get(step)
            if sender != self.id:
                continue
            if out is None or out.receiver != receiver:
                self.get_logger().warning(f'late {result} from sensor {receiver} for the handoff of step {step} '
                                          'ignored (already re-selected or done)')
                continue
            self._cancel_timer(out)
            if result == 'ack':
                self.suspects.discard(receiver)
                del self.outgoing[step]
            else:
                self.nacks += 1
                self.get_logger().warning(f'sensor {receiver} refused the handoff of step {step} '
                                          f'({st.message}); re-selecting')
                self._send_next(out, 'nack')
        self._advance()

    # -- the state machine -----------------------------------------------------------------------------
    def _advance(self) -> None:
        if self.layout is None:
            return
        while self.inbox:
            self._receive(self.inbox.pop(0))
        if not self.start_checked and 0 in self.truth:
            self.start_checked = True
            if start_leader_of(self.layout, self.truth[0], self.noise, self.p.seed) == self.id:
                self.get_logger().info(f'sensor {self.id} has the highest amplitude at step 0: leading from a '
                                       'uniform belief')
                if self.pending is None:
                    self.pending = _Pending(uniform_belief(self.grid), 0, None)
        while self.pending is not None and self.pending.step in self.truth:
            pend, self.pending = self.pending, None
            self._lead(pend)

    def _receive(self, data: bytes) -> None:
        h, why = receive_handoff(data, self.grid, self.layout.n, receiver=self.id)
        head = peek_header(data)
        if why is None and self.pending is not None:
            why = f'busy: already holding the belief for step {self.pending.step}'
        elif why is None and h.step + 1 <= self.last_led:
            why = f'stale: step {h.step + 1} is not after step {self.last_led}, already led here'
        if why is not None:
            self.refused += 1
            who = f'sensor {head[0]}, step {head[2]}' if head else 'an unreadable header'
            self.get_logger().warning(f'refused handoff from {who}: {why}')
            if head is not None and head[0] < self.layout.n:
                self._reply(head[0], head[2], why)
            return
        self._reply(h.sender, h.step, None)
        self.pending = _Pending(h.belief(), h.step + 1, h.sender)

    def _reply(self, sender: int, step: int, refusal: str | None) -> None:
        status = diagnostic_status(
            f'sensor_{self.id}', DIAG_OK if refusal is None else DIAG_WARN,
            'ack' if refusal is None else f'refused: {refusal}',
            {'step': step, 'sender': sender, 'receiver': self.id, 'result': 'ack' if refusal is None else 'nack'})
        t = stamp_of_step(step, self.p.dt)  # the step's time; a malformed header may carry any u32 step
        self._ack_pub(sender).publish(diagnostic_array(t if t < 2**31 - 1 else 0.0, [status]))

    def _lead(self, pend: _Pending) -> None:
        """Table 1 steps 1-5 for step ``pend.step`` (the core's ``leader_step``), then publish and hand off."""
        step, layout = pend.step, self.layout
        z = simulate_measurement(loudest(self.truth[step], self.position), self.position, self.is_doa, self.noise,
                                 measurement_normal(self.p.seed, self.id, step))
        rng = selection_rng(self.p.seed, self.id, step) if self.p.selection == 'random' else None
        res = leader_step(pend.belief, z, self.id, layout, self.tp, step=step, previous=pend.previous,
                          selection=self.p.selection, rng=rng)
        self.last_led = step
        self.led.append(step)
        t = stamp_of_step(step, self.p.dt)
        est = res.estimate
        P = np.diag([0.0, UNUSED_VARIANCE, 0.0, UNUSED_VARIANCE])
        P[np.ix_([0, 2], [0, 2])] = est.cov
        self.pub_est.publish(cv_state_to_odometry(t, np.array([est.mean[0], 0.0, est.mean[1], 0.0]), P,
                                                  FRAME_MAP, self.p.track_id))
        xy = res.belief.centers()
        self.pub_belief.publish(table_to_pointcloud2(t, FRAME_MAP, {'x': xy[:, 0], 'y': xy[:, 1],
                                                                    'p': res.belief.mass}))
        order = handoff_order(res.candidates, res.scores, layout.neighbours[self.id], pend.previous, self.id,
                              first=res.next_leader, last=self.suspects)
        self.pub_markers.publish(sensor_markers(t, layout, self.id, order[0], est.mean, est.cov))
        self._diag('step', step, order[0], {
            'previous': -1 if pend.previous is None else pend.previous, 'z': z, 'updated': res.updated,
            'belief_size': est.size, 'spread_m2': est.spread,
            'candidates': ' '.join(str(int(c)) for c in res.candidates),
            'mi_bits': ' '.join(f'{s:.6g}' for s in res.scores),
            'handoff_bytes': len(res.payload) if order[0] != self.id else 0})
        self.outgoing[step] = out = _Outgoing(step, res.belief, order)
        self._send_next(out, None)

    def _send_next(self, out: _Outgoing, why: str | None) -> None:
        """Hand ``out`` to the next sensor in its order (``why``: reason of a re-selection)."""
        if why is not None:
            out.tried.append(out.receiver)
        k = out.order.pop(0)
        if k == self.id:
            del self.outgoing[out.step]
            if why is not None:
                self.get_logger().warning(f'no neighbour took the handoff of step {out.step} (tried {out.tried}); '
                                          f'sensor {self.id} leads step {out.step + 1} itself')
                self._diag('self', out.step, k, {'tried': ' '.join(map(str, out.tried)), 'handoff_bytes': 0})
            if self.pending is not None:
                self.get_logger().warning(f'dropping the belief of step {out.step}: already holding the one for '
                                          f'step {self.pending.step}')
                return
            self.pending = _Pending(out.belief, out.step + 1, None)
            return
        payload = encode_handoff(Handoff.from_belief(out.step, self.id, k, out.belief))
        if why is not None:
            self._diag('reselect', out.step, k, {'failed': out.receiver, 'reason': why, 'handoff_bytes': len(payload)})
        out.receiver = k
        self._handoff_pub(k).publish(handoff_to_uint8_array(payload))
        out.timer = self.create_timer(self.p.ack_timeout, lambda: self._on_ack_timeout(out.step, k),
                                      clock=self._steady)

    def _cancel_timer(self, out: _Outgoing) -> None:
        if out.timer is not None:
            out.timer.cancel()
            self.destroy_timer(out.timer)
            out.timer = None

    def _on_ack_timeout(self, step: int, receiver: int) -> None:
        out = self.outgoing.get(step)
        if out is None or out.receiver != receiver:
            return
        self._cancel_timer(out)
        self.timeouts += 1
        self.suspects.add(out.receiver)
        self.get_logger().warning(f'no ack from sensor {out.receiver} for the handoff of step {out.step} within '
                                  f'{self.p.ack_timeout:g} s; re-selecting')
        self._send_next(out, 'timeout')
        self._advance()

    def _diag(self, event: str, step: int, nxt: int, values: dict) -> None:
        t = stamp_of_step(step, self.p.dt)
        status = diagnostic_status(f'sensor_{self.id}', DIAG_OK if event == 'step' else DIAG_WARN,
                                   f'{event} {step}: sensor {self.id} -> sensor {nxt}',
                                   {'event': event, 'step': step, 'leader': self.id, 'next': nxt, **values})
        self.pub_leader.publish(diagnostic_array(t, [status]))


def main_for(cls, argv=None) -> int:
    """``main`` of the thin executables (``acoustic_sensor``, ``doa_sensor``)."""
    return run_node(cls, argv)
