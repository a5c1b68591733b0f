"""``acoustic_sensor`` and ``doa_sensor``: one node per sensor of the IDSQ network.

Each instance is one sensor (``id``, ``position``, ``type``); the rest of the network comes from
``vehicle_sim``'s transient-local ``/idsq/layout``, which must agree with those three parameters
(else one error line and the node stays passive); a zero layout stamp means "origin pending". The
protocol is ``track_core.idsq.leader_protocol.HandoffLedger``; this node converts messages and
carries out its effects. It never reads a truth.

- in: ``/idsq/sensor_<id>/reading`` (step s stamped origin + (s + 1)·Δt; amplitude, and for a DOA
  sensor the REP-103 direction in map read as θ = wrap(π/2 − direction)), ``/idsq/election``, and
  ``/idsq/sensor_<id>/handoff``, ``.../ack``, ``.../revoke`` (``records.idsq``).
- out: its step-0 reading once on ``/idsq/election``; replies on the sender's ack topic; when
  leading, ``/idsq/estimate`` (Odometry), ``/idsq/belief``, ``/idsq/markers``, ``/idsq/leader``
  events (``void`` when revoked) and the handoff or revokes it sends on.
- QoS: handoff, ack, revoke reliable transient-local (depth 4); readings reliable depth 256,
  volatile or transient-local (``reading_durability``); election ``ELECTION_QOS``.
- ``reading_timeout`` (steady clock): a missing reading makes a predict-only lead (``missed``), a
  late one is dropped (``late``); the election decides on those heard (``unheard``). Ack timeouts
  run on the steady clock too.
- Endpoints without QoS-event handlers and no /clock subscription (many sensors share a process);
  refusals through ``TrackNode.refuse``. In full: docs/MODULES.md, "The IDSQ sensor nodes in full".
"""

from __future__ import annotations

import dataclasses
from collections import deque

import numpy as np
from nav_msgs.msg import Odometry
from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.qos import QoSProfile
from sensor_msgs.msg import PointCloud2
from visualization_msgs.msg import MarkerArray

from track_core.idsq import leader_protocol as protocol
from track_msgs import msg as tm
from track_msgs_py.covariance import NOT_ESTIMATED_VARIANCE
from track_msgs_py.markers.idsq import sensor_markers
from track_msgs_py.odometry import cv_state_to_odometry
from track_msgs_py.qos import (
    ELECTION_QOS,
    ESTIMATE_QOS,
    HANDOFF_QOS,
    READING_LATCHED_QOS,
    READING_QOS,
    SENSOR_QOS,
    STATIC_QOS,
)
from track_msgs_py.records.idsq import (
    PROTOCOL,
    IdsqAck,
    IdsqBelief,
    IdsqHandoff,
    IdsqLeaderEvent,
    IdsqReading,
    IdsqRevoke,
    RecordError,
    leader_event,
    pointcloud2_to_layout,
    received_handoff,
)
from track_msgs_py.stamps import stamp_to_sec
from track_msgs_py.topics import (
    CLOCK,
    FRAME_MAP,
    IDSQ_BELIEF,
    IDSQ_ELECTION,
    IDSQ_ESTIMATE,
    IDSQ_LAYOUT,
    IDSQ_LEADER,
    IDSQ_MARKERS,
    idsq_ack_topic,
    idsq_handoff_topic,
    idsq_reading_topic,
    idsq_revoke_topic,
)
from track_nodes.base import ParameterError, TrackNode
from track_nodes.idsq.params import DoaSensorParams, SensorParams, sensor_setup


class IdsqSensorNode(TrackNode):
    """One sensor of the IDSQ network; ``AcousticSensorNode`` / ``DoaSensorNode`` fix the type."""

    DEFAULT_NAME = 'idsq_sensor'
    SENSOR_TYPE = 'acoustic'
    Params = SensorParams
    p: SensorParams  # the declared parameters (base/params.py)

    def setup(self) -> None:
        p = self.p
        if p.type != self.SENSOR_TYPE:
            raise ParameterError(f'parameter type={p.type!r} is invalid for {self.DEFAULT_NAME}: allowed '
                                 f'{self.SENSOR_TYPE!r} (run {p.type}_sensor for a {p.type} sensor)')
        pos = np.asarray(p.position, dtype=float)
        if pos.shape != (2,) or not np.all(np.isfinite(pos)):
            raise ParameterError(f'parameter position={list(p.position)!r} is invalid: allowed 2 finite numbers')
        self.id, self.position, self.is_doa = int(p.id), pos, p.type == 'doa'
        self.core = protocol.HandoffLedger(sensor_setup(p, pos))
        self.disabled = False
        self.origin: float | None = None  # the layout's stamp: step s is stamped origin + (s + 1)·dt
        # readings and election messages before the layout's origin, in their order
        self.early: deque[tuple[tm.IdsqReading, bool]] = deque(maxlen=protocol.READING_WINDOW)
        self.ack_timers: dict[tuple[int, int], object] = {}  # (step, receiver) → steady-clock ack timer
        self.reading_wait: tuple[int, object] | None = None  # (step, steady-clock timer) of the reading awaited
        self.election_timer = None
        self.relayed = False  # own step-0 reading relayed on the election topic
        self.reading_topic = idsq_reading_topic(self.id)
        for sub in [s for s in self.subscriptions if s.topic_name == CLOCK]:
            self.destroy_subscription(sub)  # no ROS clock needed (module docstring)
        self.pubs: dict[tuple[str, int], object] = {}  # (handoff | ack | revoke, sensor) → publisher
        self.pub_est = self._pub(Odometry, IDSQ_ESTIMATE, ESTIMATE_QOS)
        self.pub_belief = self._pub(PointCloud2, IDSQ_BELIEF, SENSOR_QOS)
        self.pub_markers = self._pub(MarkerArray, IDSQ_MARKERS, ESTIMATE_QOS)
        self.pub_leader = self._pub(tm.IdsqLeaderEvent, IDSQ_LEADER, ESTIMATE_QOS)
        self.pub_election = self._pub(tm.IdsqReading, IDSQ_ELECTION, ELECTION_QOS)
        self._sub(PointCloud2, IDSQ_LAYOUT, self._on_layout, STATIC_QOS)
        self._sub(tm.IdsqReading, self.reading_topic, lambda m: self._on_reading(m, False),
                  READING_LATCHED_QOS if p.reading_durability == 'transient_local' else READING_QOS)
        self._sub(tm.IdsqReading, IDSQ_ELECTION, lambda m: self._on_reading(m, True), ELECTION_QOS)
        self._sub(tm.IdsqHandoff, idsq_handoff_topic(self.id), self._on_handoff, HANDOFF_QOS)
        self._sub(tm.IdsqAck, idsq_ack_topic(self.id), self._on_ack, HANDOFF_QOS)
        self._sub(tm.IdsqRevoke, idsq_revoke_topic(self.id), self._on_revoke, HANDOFF_QOS)

    # the ledger's state, as the tests and the launcher's summary see it
    layout = property(lambda self: self.core.layout)
    pending = property(lambda self: self.core.pending)
    led = property(lambda self: self.core.led)
    refused = property(lambda self: self.core.refused)
    timeouts = property(lambda self: self.core.timeouts)
    nacks = property(lambda self: self.core.nacks)
    missed = property(lambda self: len(self.core.missed))  # steps led predict-only (no reading in time)
    late = property(lambda self: self.core.late)  # readings dropped: their step was led without them
    unheard = property(lambda self: self.core.unheard)  # sensors the election decided without

    def _pub(self, cls, topic: str, qos: QoSProfile):
        return self.create_publisher(cls, topic, qos,
                                     event_callbacks=PublisherEventCallbacks(use_default_callbacks=False))

    def _sub(self, cls, topic: str, callback, qos: QoSProfile):
        return self.create_subscription(cls, topic, callback, qos,
                                        event_callbacks=SubscriptionEventCallbacks(use_default_callbacks=False))

    def _proto_pub(self, kind: str, k: int):
        """The ``kind`` publisher to sensor ``k``: handoffs' and acks' made at layout time, revokes' (rare)
        when first sent; transient-local delivers what a late one publishes once it matches."""
        if (kind, k) not in self.pubs:
            cls, topic = PROTOCOL[kind]
            self.pubs[(kind, k)] = self._pub(cls, topic(k), HANDOFF_QOS)
        return self.pubs[(kind, k)]

    # -- inputs -------------------------------------------------------------------------------------
    def _on_layout(self, msg: PointCloud2) -> None:
        if self.origin is not None or self.disabled:
            return
        try:
            layout = pointcloud2_to_layout(msg, self.p.comm_range)
        except ValueError as exc:
            self.get_logger().error(f'{self.resolved(IDSQ_LAYOUT)}: unusable layout: {exc}')
            return
        if self.layout is not None:  # the stamped copy of a layout that came with its origin pending
            if not (np.array_equal(layout.positions, self.layout.positions)
                    and np.array_equal(layout.is_doa, self.layout.is_doa)):
                self.get_logger().error(f'{self.resolved(IDSQ_LAYOUT)}: sensor {self.id}: a second, different '
                                        'layout; keeping the first')
                return
            self._set_origin(msg)
            return
        why = protocol.layout_problem(layout, self.id, self.position, self.is_doa)
        if why is not None:
            self.disabled = True
            self.get_logger().error(f'{self.resolved(IDSQ_LAYOUT)}: sensor {self.id}: {why}; staying passive')
            return
        targets = [protocol.handoff_targets(layout, j) for j in range(layout.n)]  # K sensors
        for k in targets[self.id]:
            self._proto_pub('handoff', k)
        for j in range(layout.n):  # whom I may have to answer
            if self.id in targets[j]:
                self._proto_pub('ack', j)
        self._do(self.core.set_layout(layout))
        self._set_origin(msg)

    def _set_origin(self, msg: PointCloud2) -> None:
        """The layout's stamp is the step origin; 0 means pending (its publisher's /clock had not
        started), and a stamped copy of the same layout follows."""
        if msg.header.stamp.sec == 0 and msg.header.stamp.nanosec == 0:
            return
        self.origin = stamp_to_sec(msg.header.stamp)
        while self.early:  # the readings that came first, in their order
            self._on_reading(*self.early.popleft())

    def _on_reading(self, msg: tm.IdsqReading, election: bool) -> None:
        """A reading of this sensor (``election`` False) or a sensor's step-0 amplitude (``election``)."""
        if self.origin is None:  # steps count from the layout's stamp: hold the reading until it comes
            if not self.disabled:
                self.early.append((msg, election))
            return
        topic = IDSQ_ELECTION if election else self.reading_topic
        try:
            r = IdsqReading.from_msg(msg)
        except RecordError as exc:
            self.refuse(topic, str(exc))
            return
        t = r.t - self.origin
        step = protocol.step_of_stamp(r.t, self.p.dt, self.origin)
        if election:
            reason = (f'sensor_id: {r.sensor} is not in the layout of {self.layout.n} sensors'
                      if r.sensor >= self.layout.n else
                      f'header.stamp: {t:.9f} s after the origin is not step 0' if step != 0 else
                      f'amplitude={r.amplitude}: a step-0 amplitude must be finite' if not np.isfinite(r.amplitude)
                      else None)
        else:
            reason = r.problem(self.id, self.is_doa) or self.core.reading_problem(step, t, self.p.dt)
        if reason is not None:
            self.refuse(topic, reason)
            return
        if election:
            self._do(self.core.on_election(r.sensor, r.amplitude))
            return
        if step == 0 and not self.relayed and np.isfinite(r.amplitude):
            self.relayed = True  # tell the field my step-0 amplitude (the start rule)
            self.pub_election.publish(msg)
        self._do(self.core.on_reading(step, r.z, r.amplitude))

    def _on_handoff(self, msg: tm.IdsqHandoff, info) -> None:
        """(With the message info: the ledger refuses a handoff that arrived after the ack timeout.)"""
        src, rcv = info.get('source_timestamp', 0), info.get('received_timestamp', 0)
        age = (rcv - src) * 1e-9 if src > 0 and rcv > 0 else None
        self._do(self.core.on_handoff(received_handoff(msg), age))

    def _on_ack(self, msg: tm.IdsqAck) -> None:
        try:
            a = IdsqAck.from_msg(msg)
        except RecordError as exc:
            self.refuse(idsq_ack_topic(self.id), f'reply: {exc}')
            return
        self._do(self.core.on_reply(a.step, a.sender, a.receiver, a.result, a.reason))
        self._do(self.core.advance())

    def _on_revoke(self, msg: tm.IdsqRevoke) -> None:
        r = IdsqRevoke.from_msg(msg)
        self._do(self.core.on_revoke(r.sender, r.receiver, r.step))

    def _on_ack_timeout(self, step: int, receiver: int) -> None:
        self._do(self.core.timeout(step, receiver))

    def _on_reading_timeout(self, step: int) -> None:
        self._drop_wait()
        self._do(self.core.reading_missed(step))

    def _on_election_timeout(self) -> None:
        self._drop_timer(self.election_timer)
        self.election_timer = None
        self._do(self.core.election_timeout())

    def _arm_timers(self) -> None:
        """Arm (or drop) the steady-clock timers of the reading awaited and of the election (module docstring)."""
        step = self.core.waiting_for()
        if self.reading_wait is not None and self.reading_wait[0] != step:
            self._drop_wait()
        if step is not None and self.reading_wait is None:
            timer = self.create_timer(self.p.reading_timeout, lambda s=step: self._on_reading_timeout(s),
                                      clock=self._steady)
            self.reading_wait = (step, timer)
        if self.core.start_checked:
            self._drop_timer(self.election_timer)
            self.election_timer = None
        elif self.core.election and self.layout is not None and self.election_timer is None:
            self.election_timer = self.create_timer(self.p.reading_timeout, self._on_election_timeout,
                                                    clock=self._steady)

    def _drop_wait(self) -> None:
        if self.reading_wait is not None:
            self._drop_timer(self.reading_wait[1])
            self.reading_wait = None

    def _drop_timer(self, timer) -> None:
        if timer is not None:
            timer.cancel()
            self.destroy_timer(timer)

    # -- effects ------------------------------------------------------------------------------------
    def _do(self, effects) -> None:
        """Carry out the ledger's effects, in order, then re-arm the reading and election timers."""
        self._carry_out(effects)
        self._arm_timers()

    def _carry_out(self, effects) -> None:
        for fx in effects:
            if isinstance(fx, protocol.Log) and fx.refusal is not None:  # counted, throttled, on /diagnostics
                channel, reason = fx.refusal
                self.refuse(PROTOCOL[channel][1](self.id), reason)
            elif isinstance(fx, protocol.Log) and fx.level == 'info':  # (rclpy: one severity per call site)
                self.get_logger().info(fx.text)
            elif isinstance(fx, protocol.Log):
                self.get_logger().warning(fx.text)
            elif isinstance(fx, protocol.Reply):  # (an absurd step has no stamp: records.idsq stamps it 0)
                self._proto_pub('ack', fx.sender).publish(IdsqAck.reply(fx.step, fx.sender, self.id, fx.refusal,
                                                                        self._t(fx.step)).to_msg())
            elif isinstance(fx, protocol.Led):
                self._publish_led(fx)
            elif isinstance(fx, (protocol.Reselect, protocol.SelfLead, protocol.Void)):
                self._event(leader_event(fx, self.id))
            elif isinstance(fx, protocol.Send):
                self._proto_pub('handoff', fx.receiver).publish(
                    IdsqHandoff.from_handoff(self._t(fx.step), fx.handoff).to_msg())
                self._disarm(fx.step, fx.receiver)
                self.ack_timers[(fx.step, fx.receiver)] = self.create_timer(
                    self.p.ack_timeout, lambda s=fx.step, k=fx.receiver: self._on_ack_timeout(s, k),
                    clock=self._steady)
            elif isinstance(fx, protocol.Disarm):
                self._disarm(fx.step, fx.receiver)
            elif isinstance(fx, protocol.Revoke):  # the chain rule (track_core.idsq.leader_protocol)
                self.get_logger().warning(fx.text)
                self._proto_pub('revoke', fx.receiver).publish(
                    IdsqRevoke(fx.step, self.id, fx.receiver, self._t(fx.step)).to_msg())

    def _disarm(self, step: int, receiver: int) -> None:
        timer = self.ack_timers.pop((step, receiver), None)
        if timer is not None:
            timer.cancel()
            self.destroy_timer(timer)

    def _publish_led(self, fx: protocol.Led) -> None:
        """The outputs of a led step: estimate, belief cloud, markers, the ``step`` event."""
        t, res, est = self._t(fx.step), fx.result, fx.result.estimate
        P = np.diag([0.0, NOT_ESTIMATED_VARIANCE, 0.0, NOT_ESTIMATED_VARIANCE])  # velocity
        P[np.ix_([0, 2], [0, 2])] = est.cov
        self.pub_est.publish(cv_state_to_odometry(t, np.array([est.mean[0], 0.0, est.mean[1], 0.0]), P,
                                                  FRAME_MAP, self.p.track_id))
        xy = res.belief.centers()
        self.pub_belief.publish(IdsqBelief(t, xy, res.belief.mass).to_msg())
        self.pub_markers.publish(sensor_markers(t, self.layout, self.id, fx.next, est.mean, est.cov))
        self._event(leader_event(fx, self.id))

    def _t(self, step: int) -> float:
        """The stamp of ``step``'s outputs (``stamp_of_step`` from the layout's origin)."""
        return protocol.stamp_of_step(step, self.p.dt, self.origin or 0.0)

    def _event(self, ev: IdsqLeaderEvent) -> None:
        self.pub_leader.publish(dataclasses.replace(ev, t=self._t(ev.step)).to_msg())


class AcousticSensorNode(IdsqSensorNode):
    """``acoustic_sensor``: an acoustic-amplitude sensor of the IDSQ network (eqs. 5-6)."""

    DEFAULT_NAME = 'acoustic_sensor'
    SENSOR_TYPE = 'acoustic'


class DoaSensorNode(IdsqSensorNode):
    """``doa_sensor``: a direction-of-arrival (bearing) sensor of the IDSQ network (eq. 11, Fig. 6)."""

    DEFAULT_NAME = 'doa_sensor'
    SENSOR_TYPE = 'doa'
    Params = DoaSensorParams
