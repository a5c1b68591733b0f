"""``foxglove_bridge`` (``track-foxglove``): the live ROS graph served to Foxglove over its WebSocket protocol.

Usage::

    track-foxglove [--port 8765] [--address 127.0.0.1] [-e REGEX] [--clock auto|sim|wall] [--ros-args ...]
    ros2 run track_nodes foxglove_bridge --ros-args -p port:=8765 -p address:=0.0.0.0

then in Foxglove: *Open connection → Foxglove WebSocket → ws://HOST:8765*. The server is the
Foxglove SDK's (``foxglove-sdk``, PyPI; the C++ bridge is not), subprotocol ``foxglove.sdk.v1``
behind a front (``foxglove/front.py``) that refuses another subprotocol in words.

- Served: every topic with a publisher (``regex``: ``re.search``), one channel each, encoding
  ``cdr``, a ``ros2msg`` schema from ``bag.typestore`` (unknown types left out with one warning).
- Discovery every ``discovery_period`` s (steady clock); a topic whose publishers go keeps its
  channel id for ``withdraw_after`` s; another type gets a new channel.
- Raw subscriptions, made only while a client subscribes; QoS as the recorder's with a live queue
  (``LIVE_DEPTH``); transient-local topics resubscribed per client subscription.
- Time (``clock``): ``auto`` follows ``/clock`` once published (broadcast to clients), else wall
  time every ``TIME_PERIOD`` s; ``sim``: the node's clock; ``wall``: no time capability.
- SIGINT, SIGTERM, SIGHUP stop cleanly (exit 0); a port in use is one line, exit 2. In full:
  docs/MODULES.md, "The Foxglove bridge in full".
"""

from __future__ import annotations

import re
import sys
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass

from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.parameter import Parameter

from track_msgs_py.topics import CLOCK
from track_nodes.bag.api import msg_class, recording_qos
from track_nodes.base import ParameterError, TrackNode, param, run_node
from track_nodes.base.cli import OneLineParser, cli_overrides
from track_nodes.foxglove.front import Front

SCHEMA_ENCODING = 'ros2msg'
MESSAGE_ENCODING = 'cdr'
LIVE_DEPTH = 100  # queue of a volatile subscription; a live view wants the newest, not a backlog
LATCHED_DEPTH = 1000  # transient-local: every publisher's latched sample (one per node on /tf_static)
TIME_PERIOD = 0.1  # [wall s] between broadcasts of the wall time while no /clock is followed (clock auto)
REFUSAL_THROTTLE = 5.0  # [s] at most one log line about refused clients this often
CLOCK_MODES = ('auto', 'sim', 'wall')


@dataclass
class FoxgloveBridgeParams:
    """Parameters of ``foxglove_bridge``."""

    port: int = param(8765, 'TCP port of the WebSocket server (0: any free port, logged at start)', 0, 65535)
    address: str = param('127.0.0.1', 'address to listen on (0.0.0.0: every interface; the default: this machine)')
    regex: str = param('', 'serve only topics matching this regular expression (re.search); empty: all')
    discovery_period: float = param(0.5, 'interval between graph polls for new and vanished topics [s]', 0.01, 60.0)
    withdraw_after: float = param(60.0, 'a topic without publishers stays advertised (same channel id) this long, '
                                  'so clients keep their subscription across a node restart; 0: withdrawn at once '
                                  '[s]', 0.0, 1e9)
    clock: str = param('auto', "time: 'auto' (follow /clock when it is published, else wall time), 'sim' or 'wall'",
                       choices=CLOCK_MODES)


def ros2msg_schema(typestore, msgtype: str) -> bytes:
    """The ``ros2msg`` schema of ``msgtype`` as MCAP and Foxglove expect it: the definition, then every
    dependency after a ``====`` line and ``MSG: pkg/Type`` (what the recorder embeds in its bags)."""
    text, _ = typestore.generate_msgdef(msgtype, ros_version=2)
    return text.encode()


class _Listener:
    """The SDK's ``ServerListener``: which channels clients watch (called from the server's threads)."""

    def __init__(self, bridge: FoxgloveBridgeNode) -> None:
        self.bridge = bridge

    def on_subscribe(self, client, channel) -> None:
        self.bridge.client_subscribed(channel.id, +1)

    def on_unsubscribe(self, client, channel) -> None:
        self.bridge.client_subscribed(channel.id, -1)


class FoxgloveBridgeNode(TrackNode):
    """Serve every topic of the ROS graph to Foxglove over its WebSocket protocol (ros2msg schemas, raw CDR)."""

    DEFAULT_NAME = 'foxglove_bridge'
    Params = FoxgloveBridgeParams
    p: FoxgloveBridgeParams  # the declared parameters (base/params.py)

    def setup(self) -> None:
        import foxglove
        from foxglove.websocket import Capability

        from track_nodes.bag.typestore import typestore

        p = self.p
        try:
            self.regex = re.compile(p.regex) if p.regex else None
        except re.error as exc:
            raise ParameterError(f'parameter regex={p.regex!r} is not a valid regular expression: {exc}') from None
        self.typestore = typestore()  # the Jazzy types and track_msgs (bag/typestore.py)
        self._lock = threading.Lock()
        self.channels: dict[str, object] = {}  # topic -> foxglove.Channel
        self.types: dict[str, str] = {}  # topic -> the type it is served with
        self._topic_of: dict[int, str] = {}  # channel id -> topic
        self._watchers: dict[int, int] = {}  # channel id -> clients subscribed (the listener's count)
        self._fresh: set[int] = set()  # channel ids with a new client since the last reconcile
        self.subscriptions_by_topic: dict[str, object] = {}
        self.skipped: set[str] = set()
        self.forwarded: dict[str, int] = {}  # messages handed to the server, per topic
        self.gone: dict[str, float] = {}  # topic -> steady time its publishers went (still advertised)
        sim = bool(self.get_parameter('use_sim_time').value)
        if p.clock == 'wall' and sim:
            raise ParameterError('parameter clock=wall contradicts use_sim_time=true: choose one')
        if p.clock == 'sim' and not sim:
            self.set_parameters([Parameter('use_sim_time', value=True)])
        self._sim = sim or p.clock == 'sim'
        self._auto = p.clock == 'auto' and not self._sim
        self.following = False  # clock auto: /clock is published and followed
        self.latest_clock = 0  # the last /clock value received [ns]
        self._fox = foxglove.Context()  # this node's channels only (not the SDK's global context)
        self._serve([Capability.Time] if p.clock != 'wall' else [])
        # The listener only records; subscriptions change on the executor's thread (a guard condition wakes it).
        self._wake = self.create_guard_condition(self.reconcile)
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.discovery_timer = self.create_timer(p.discovery_period, self.discover, clock=steady)
        if p.clock != 'wall':
            from rclpy.qos import QoSProfile, ReliabilityPolicy
            from rosgraph_msgs.msg import Clock as ClockMsg

            # best effort: matches any /clock publisher (the launcher's, the player's, a reliable one)
            self.create_subscription(ClockMsg, CLOCK, self._on_clock,
                                     QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT))
        if self._auto:
            self.time_timer = self.create_timer(TIME_PERIOD, self._broadcast_wall_time, clock=steady)
        what = f'topics matching {p.regex!r}' if self.regex else 'every topic'
        self.get_logger().info(f'serving {what} to Foxglove on ws://{p.address}:{self.port}')
        self.discover()

    def _serve(self, capabilities: list) -> None:
        """The SDK's server on a free local port; clients come through the front (foxglove/front.py)."""
        import foxglove

        p = self.p
        self.server = self.front = None
        self.refusals = 0
        try:
            self.server = foxglove.start_server(
                name=self.get_fully_qualified_name(), host='127.0.0.1', port=0, context=self._fox,
                capabilities=capabilities, supported_encodings=[MESSAGE_ENCODING], server_listener=_Listener(self))
            self.front = Front(p.address, p.port, self.server.port, self._refused)
        except Exception as exc:  # the SDK raises its own error type for a bind failure
            if self.server is not None:
                self.server.stop()
                self.server = None
            raise OSError(f'cannot serve on {p.address}:{p.port}: {" ".join(str(exc).split())}') from None
        self.port = self.front.port

    # -- the graph ---------------------------------------------------------------------------------
    def wanted(self, topic: str) -> bool:
        return self.regex is None or self.regex.search(topic) is not None

    def discover(self) -> None:
        """Advertise the topics that appeared, unadvertise those without publishers any more."""
        import foxglove

        present = set()
        now = time.monotonic()
        for topic, types in self.get_topic_names_and_types():
            if topic in self.skipped or not self.wanted(topic):
                continue
            if not Node.count_publishers(self, topic):  # the graph's name as is (TrackNode's resolves relative)
                continue  # subscribers only: type and QoS unknown, nothing to show
            present.add(topic)
            msgtype = types[0]
            if topic in self.channels:
                if self.types[topic] == msgtype:
                    if self.gone.pop(topic, None) is not None:  # back: the same channel, the same id
                        self._requalify(topic)
                    continue
                self._unadvertise(topic)  # back with another type: a channel of its own
            if len(types) > 1:
                self.get_logger().warning(f'{topic} has several types {types}; serving {msgtype}')
            try:
                msg_class(msgtype)  # rclpy needs the class even for a raw subscription
                schema = ros2msg_schema(self.typestore, msgtype)
            except (ValueError, KeyError) as exc:
                self.get_logger().warning(f'not serving {topic}: {exc}')
                self.skipped.add(topic)
                continue
            channel = foxglove.Channel(topic, message_encoding=MESSAGE_ENCODING, context=self._fox,
                                       schema=foxglove.Schema(name=msgtype, encoding=SCHEMA_ENCODING, data=schema))
            with self._lock:
                self.channels[topic] = channel
                self.types[topic] = msgtype
                self._topic_of[channel.id()] = topic
                self.forwarded.setdefault(topic, 0)
        for topic in [t for t in self.channels if t not in present]:
            since = self.gone.setdefault(topic, now)  # its subscription stays: DDS matches the next publisher
            if now - since >= self.p.withdraw_after:
                self._unadvertise(topic)
        if self.following and not Node.count_publishers(self, CLOCK):
            self.following = False
            self.get_logger().info('no /clock publisher any more: log times and the broadcast time are wall time')
        self.reconcile()

    def _unadvertise(self, topic: str) -> None:
        self.gone.pop(topic, None)
        with self._lock:
            channel = self.channels.pop(topic)
            self.types.pop(topic, None)
            self._topic_of.pop(channel.id(), None)
            self._watchers.pop(channel.id(), None)
        self._unsubscribe(topic)
        channel.close()

    # -- clients -----------------------------------------------------------------------------------
    def client_subscribed(self, channel_id: int, change: int) -> None:
        """A client subscribed (+1) or unsubscribed (-1) ``channel_id``; any thread."""
        with self._lock:
            self._watchers[channel_id] = max(0, self._watchers.get(channel_id, 0) + change)
            if change > 0:
                self._fresh.add(channel_id)
        self._wake.trigger()

    def reconcile(self) -> None:
        """Subscribe to the watched channels' topics, drop the unwatched ones (executor thread)."""
        with self._lock:
            watched = {t for cid, n in self._watchers.items() if n and (t := self._topic_of.get(cid))}
            fresh = {t for cid in self._fresh if (t := self._topic_of.get(cid))}
            self._fresh.clear()
        for topic in list(self.subscriptions_by_topic):
            if topic not in watched:
                self._unsubscribe(topic)
        for topic in sorted(watched - self.gone.keys()):  # a gone topic is subscribed (again) when it is back
            sub = self.subscriptions_by_topic.get(topic)
            if sub is not None and topic in fresh and self._latched(topic):
                self._unsubscribe(topic)  # a new reader: DDS delivers the latched samples to the new client
                sub = None
            if sub is None:
                self._subscribe(topic)

    def _requalify(self, topic: str) -> None:
        """A topic is back: keep its subscription if it suits the new publishers' QoS, else make it anew."""
        sub = self.subscriptions_by_topic.get(topic)
        infos = self.get_publishers_info_by_topic(topic)
        if sub is None or not infos:
            return
        qos = recording_qos([i.qos_profile for i in infos])
        if (qos.reliability, qos.durability) != (sub.qos_profile.reliability, sub.qos_profile.durability):
            self._unsubscribe(topic)  # reconcile subscribes again, with the new QoS

    def _latched(self, topic: str) -> bool:
        return self.subscriptions_by_topic[topic].qos_profile.durability.name == 'TRANSIENT_LOCAL'

    def _subscribe(self, topic: str) -> None:
        infos = self.get_publishers_info_by_topic(topic)
        if not infos:
            return  # gone since the last poll; the next discover unadvertises it
        qos = recording_qos([i.qos_profile for i in infos])
        qos.depth = LATCHED_DEPTH if qos.durability.name == 'TRANSIENT_LOCAL' else LIVE_DEPTH
        channel = self.channels[topic]
        self.subscriptions_by_topic[topic] = self.create_subscription(
            msg_class(self.types[topic]), topic, lambda data, t=topic, c=channel: self._forward(t, c, data), qos,
            raw=True, as_given=True)  # discovered, fully qualified names

    def _unsubscribe(self, topic: str) -> None:
        sub = self.subscriptions_by_topic.pop(topic, None)
        if sub is not None:
            self.destroy_subscription(sub)

    def _forward(self, topic: str, channel, data: bytes) -> None:
        log_time = self.latest_clock if self.following else self.get_clock().now().nanoseconds
        channel.log(data, log_time=log_time)
        self.forwarded[topic] += 1

    def _on_clock(self, msg) -> None:
        ns = msg.clock.sec * 1_000_000_000 + msg.clock.nanosec
        self.latest_clock = ns
        if self._auto and not self.following:
            self.following = True
            self.get_logger().info('/clock is published: log times and the broadcast time follow it (sim time)')
        if self.server is not None:
            self.server.broadcast_time(ns)

    def _refused(self, line: str) -> None:
        """A client refused at the handshake (the front's thread): one line, at most every REFUSAL_THROTTLE s."""
        self.refusals += 1
        if self.context.ok():
            self.get_logger().warning(f'refused a client ({self.refusals} so far): {line}',
                                      throttle_duration_sec=REFUSAL_THROTTLE)

    def _broadcast_wall_time(self) -> None:
        """clock auto without /clock: Foxglove's time is the wall time (the time capability wants one)."""
        if not self.following and self.server is not None:
            self.server.broadcast_time(time.time_ns())

    # -- stop ----------------------------------------------------------------------------------------
    def destroy_node(self) -> None:
        server = getattr(self, 'server', None)
        if server is not None:
            self.server = None
            if self.front is not None:
                self.front.stop()  # every client gets 1001 (going away)
            server.stop()
            for channel in list(self.channels.values()):
                channel.close()
            line = (f'stopped: forwarded {sum(self.forwarded.values())} messages of '
                    f'{sum(1 for n in self.forwarded.values() if n)} topics')
            if self.context.ok():
                self.get_logger().info(line)
            else:  # after shutdown the logger can no longer reach /rosout and complains
                print(f'[INFO] [{self.get_name()}]: {line}', file=sys.stderr)
        super().destroy_node()


def parse_cli(argv: Sequence[str]) -> list[Parameter]:
    """Non-ROS CLI arguments → parameter overrides (``--ros-args`` are left to rclpy)."""
    ap = OneLineParser(prog='track-foxglove',
                       description='Serve every ROS topic to Foxglove (Open connection → Foxglove WebSocket → '
                                   'ws://ADDRESS:PORT): ros2msg schemas, raw CDR, /tf and /tf_static included.')
    ap.add_argument('--port', type=int, default=None, help='TCP port (default 8765; 0: any free port)')
    ap.add_argument('--address', default=None,
                    help='address to listen on (default 127.0.0.1, this machine only; 0.0.0.0: every interface)')
    ap.add_argument('-e', '--regex', default=None, help='serve only topics matching REGEX (default: all)')
    ap.add_argument('--clock', choices=CLOCK_MODES, default=None,
                    help="time: follow /clock when it is published, else wall time (auto, the default); 'sim' or "
                         "'wall' forces one")
    return cli_overrides(ap, argv, {'port': 'port', 'address': 'address', 'regex': 'regex', 'clock': 'clock'})


def main(argv: Sequence[str] | None = None) -> int:
    args = list(sys.argv if argv is None else argv)
    overrides = parse_cli(args)
    return run_node(FoxgloveBridgeNode, args, parameter_overrides=overrides or None)


if __name__ == '__main__':
    raise SystemExit(main())
