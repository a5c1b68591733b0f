"""``recorder``: record topics to a rosbag2 bag (``metadata.yaml`` + MCAP, version 9).

Usage::

    track-record NAME [-t TOPIC ...] [-e REGEX] [--no-tf] [--clock auto|sim|wall] [--flush-period S] [--ros-args ...]
    .venv/lib/track_nodes/recorder --ros-args -p bag:=NAME -p regex:=REGEX -p topics:="['/a', '/b']"

- NAME → ``bags/NAME/`` (a path if it contains '/'); never overwritten (one line, exit 2); without a
  name ``bags/rosbag2_<timestamp>/``.
- Recorded: ``topics`` plus every topic matching ``regex`` (``re.search``); with neither, every
  topic (``/rosout``, ``/parameter_events``, ``/track/ready`` only when listed). ``/tf``,
  ``/tf_static`` and ``/map_datum`` whatever the filter unless ``tf`` is false (``--no-tf``). New
  topics are found every ``discovery_period`` s (steady clock).
- Raw subscriptions; QoS from the publishers (``bag.api.recording_qos``), stored in the bag. Losses
  counted (``bag.loss_count.LossCounter``), warned every ``warn_throttle`` s, in the final line.
- Timestamps (``clock``, ``bag.clockmode``): ``auto`` follows /clock when published, else the
  receive time (decided within ``clock_wait`` s); ``sim``: the node's clock; ``wall``: receive time.
- Every ``flush_period`` s the pending chunk is written and flushed (``track-bag-recover`` after a
  SIGKILL); SIGINT, SIGTERM, SIGHUP close the bag cleanly; a full disk: one line, exit 2.
- ``metadata.yaml`` ``custom_data``: ``clock_first_ns``, ``clock_last_ns``; ``discard_empty``
  removes a bag with no message.
- A callback also takes the messages queued behind its own (``bag.batching``, ≤ ``TAKE_LIMIT``) and
  appends them as one batch (``bag.durable.write_many``, ``bag.mcap_file``, chunk CRCs). In full:
  docs/MODULES.md, "The recorder in full"; throughput: docs/results/recorder.md.
"""

from __future__ import annotations

import shutil
import sys
import threading
from collections.abc import Sequence
from dataclasses import dataclass
from datetime import datetime

from rclpy.clock import Clock, ClockType
from rclpy.event_handler import SubscriptionEventCallbacks
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile, ReliabilityPolicy

from track_nodes.bag.api import bag_path, msg_class, qos_to_rosbags, recording_qos
from track_nodes.bag.batching import can_take, take_pending
from track_nodes.bag.clockmode import MODES, ClockChoice
from track_nodes.bag.durable import open_bag
from track_nodes.bag.loss_count import LossCounter, summary_line
from track_nodes.bag.selection import TopicFilter
from track_nodes.base import TrackNode, param, run_node
from track_nodes.base.cli import OneLineParser, cli_overrides

TAKE_LIMIT = 1000  # messages taken per callback beyond the one the executor delivered
CLOCK_SPAN = ('clock_first_ns', 'clock_last_ns')  # metadata.yaml custom_data: the /clock values the run went through
CLOCK_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT)  # matches any /clock publisher

@dataclass
class RecorderParams:
    """Parameters of ``recorder``."""

    bag: str = param('', "bag name (→ bags/<name>/) or a path containing '/'; empty: rosbag2_<timestamp>")
    topics: list[str] = param([''], 'topics to record (empty: only those matching regex, or all)')
    regex: str = param('', 'record every topic matching this regular expression (re.search)')
    tf: bool = param(True, 'also record /tf, /tf_static and /map_datum when topics or regex select other topics')
    discovery_period: float = param(0.1, 'interval between graph polls for new topics [s]', 0.01, 60.0)
    flush_period: float = param(1.0, 'interval between flushes of the pending data to the file [s]', 0.01, 3600.0)
    warn_throttle: float = param(5.0, 'at most one warning about lost messages per this many seconds [s]', 0.0, 3600.0)
    clock: str = param('auto', "stamps: 'auto' (sim time if /clock is published, else wall time), 'sim' or 'wall'")
    clock_wait: float = param(2.0, "clock 'auto': wall time if no /clock this long after the first message [s]",
                              0.0, 60.0)
    discard_empty: bool = param(False, 'a bag that holds no message at the stop is removed (a refused or failed '
                                'run of a launcher leaves no empty bag behind)')


class RecorderNode(TrackNode):
    DEFAULT_NAME = 'recorder'
    Params = RecorderParams
    p: RecorderParams  # the declared parameters (base/params.py)

    def setup(self) -> None:
        self._writer = self._bag = None
        self._closed = self._said = False
        self._lock = threading.Lock()
        p = self.p
        self._stamps = ClockChoice(p.clock, self.get_parameter('use_sim_time').value, p.clock_wait)
        if self._stamps.mode == 'node':
            self.set_parameters([Parameter('use_sim_time', value=True)])  # clock sim
        self._batching = True  # until a subscription lacks take_message (bag.batching.can_take)
        self.dropped = 0  # taken after a write failed (bag.durable)
        self.filter = TopicFilter(p.topics, p.regex, p.tf)  # bag.selection
        name = p.bag or f'rosbag2_{datetime.now():%Y_%m_%d-%H_%M_%S}'
        self.path = bag_path(name)
        if self.path.exists():
            raise ValueError(f'{self.path}: bag exists already, not overwriting (choose another name)')
        from track_nodes.bag.typestore import typestore
        self.typestore = typestore()  # the Jazzy types and track_msgs
        self._bag = open_bag(self.path)  # bag.durable: the MCAP header reaches the file at once
        self._writer = self._bag.writer
        self.connections: dict[str, object] = {}
        self.counts: dict[str, int] = {}
        self.subscriptions_by_topic: dict[str, object] = {}
        self.skipped: set[str] = set()
        self.losses = LossCounter()
        # Wall-clock (steady) timers: under use_sim_time, /clock may only start once we subscribed.
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.discovery_timer = self.create_timer(p.discovery_period, self.discover, clock=steady)
        self.flush_timer = self.create_timer(p.flush_period, self.flush, clock=steady)
        # /clock: is it published (clock auto, bag.clockmode), and how far did it run (CLOCK_SPAN, every mode)
        from rosgraph_msgs.msg import Clock as ClockMsg
        self.clock_span: list[int] = []  # the first and the last /clock value received [ns]
        self.create_subscription(ClockMsg, '/clock', self._on_clock, CLOCK_QOS, as_given=True)
        self.get_logger().info(f'recording {self.filter.describe()} to {self.path}')

    # -- discovery ------------------------------------------------------------------------
    def discover(self) -> None:
        if self._closed:
            return
        self._decide()
        for topic, types in self.get_topic_names_and_types():
            if topic in self.subscriptions_by_topic:
                with self._lock:
                    self.losses.publishers(topic, self.count_publishers(topic))
                continue
            if topic in self.skipped or not self.filter.wanted(topic):
                continue
            infos = self.get_publishers_info_by_topic(topic)
            if not infos:
                continue  # only subscribers so far: type and QoS unknown
            self._subscribe(topic, types, infos)

    def _subscribe(self, topic: str, types: list[str], infos: list) -> None:
        msgtype = types[0]
        if len(types) > 1:
            self.get_logger().warning(f'{topic} has several types {types}; recording {msgtype}')
        try:
            cls = msg_class(msgtype)
            self.typestore.generate_msgdef(msgtype, ros_version=2)
        except (ValueError, KeyError) as exc:
            self.get_logger().error(f'not recording {topic}: {exc}')
            self.skipped.add(topic)
            return
        profiles = [i.qos_profile for i in infos]
        offered = [qos_to_rosbags(q) for q in profiles]
        with self._lock:
            if self._closed:
                return
            self.connections[topic] = self._writer.add_connection(
                topic, msgtype, typestore=self.typestore, offered_qos_profiles=offered)
            self.counts[topic] = 0
            self.losses.publishers(topic, len(infos))
        qos = recording_qos(profiles)
        events = SubscriptionEventCallbacks(
            message_lost=lambda info, t=topic: self._on_lost(t, info.total_count_change))
        self.subscriptions_by_topic[topic] = self.create_subscription(
            cls, topic, lambda data, info, t=topic: self._on_message(t, data, info), qos, raw=True,
            event_callbacks=events, as_given=True)  # discovered, fully qualified names
        self._batching = self._batching and can_take(self.subscriptions_by_topic[topic])
        self.get_logger().info(
            f'recording {topic} [{msgtype}] ({qos.reliability.name.lower()}, {qos.durability.name.lower()})')

    # -- writing --------------------------------------------------------------------------
    def _on_message(self, topic: str, data: bytes, info: dict | None = None) -> None:
        batch = [(data, info or {})]
        sub = self.subscriptions_by_topic.get(topic)
        if sub is not None and self._batching:
            batch += take_pending(sub, TAKE_LIMIT)  # the messages queued behind this one (bag.batching)
        self._write(topic, batch)

    def _drain(self) -> None:
        """Write what the subscriptions still hold at the stop (a stop signal can land before a take)."""
        for topic, sub in list(self.subscriptions_by_topic.items()) if self._batching else ():
            if batch := take_pending(sub, 10 * TAKE_LIMIT):
                self._write(topic, batch)

    def _write(self, topic: str, batch: list) -> None:
        raws, infos = zip(*batch, strict=True)
        with self._lock:
            if self._closed:
                self.dropped += len(raws) if self._bag.failed else 0
                return
            try:
                self._stamps.write_batch(self._bag.write_many, self.connections[topic], raws, infos, self.get_clock())
            except OSError as exc:
                self.counts[topic] += len(raws)
                return self._fail(exc)
            lost = self.losses.received_many(topic, [inf.get('publication_sequence_number') for inf in infos])
            self.counts[topic] += len(raws)
        if lost:
            self._warn_lost(topic)

    def _on_clock(self, msg) -> None:
        ns = msg.clock.sec * 1_000_000_000 + msg.clock.nanosec
        self.clock_span[:] = [self.clock_span[0] if self.clock_span else ns, ns]
        if self._stamps.mode == 'node':
            return  # the node's clock (use_sim_time) stamps; only the span is noted
        self._stamps.on_clock(ns)
        if self._stamps.mode != 'sim':
            self._decide()

    def _decide(self) -> None:
        with self._lock:
            try:
                line = None if self._closed else self._stamps.decide(self._bag.write_many)
            except OSError as exc:
                return self._fail(exc)
        if line is not None:
            self.get_logger().warning(line) if line.startswith('/clock') else self.get_logger().info(line)

    def _on_lost(self, topic: str, count_change: int) -> None:
        with self._lock:
            lost = self.losses.event(topic, count_change)
        if lost:
            self._warn_lost(topic)

    def _warn_lost(self, topic: str) -> None:
        self.get_logger().warning(f'{topic}: {self.losses.lost[topic]} messages lost so far '
                                  f'({self.losses.total()} on all topics)',
                                  throttle_duration_sec=self.p.warn_throttle)

    def flush(self) -> None:
        """Write the pending chunk and flush the file (SIGKILL safety, see bag_io)."""
        with self._lock:
            if not self._closed and self._bag is not None:
                try:
                    self._bag.flush()
                except OSError as exc:
                    self._fail(exc)

    def _fail(self, exc: OSError) -> None:
        """A write failed (disk full): the bag is closed at its last flush (bag.durable); exit 2. Holds the lock."""
        self._closed = True
        self._bag.fail(exc)
        self.exit_code = 2
        self.context.try_shutdown()  # run_nodes (or the launcher) stops; close() says what happened

    def message_counts(self) -> dict[str, int]:
        with self._lock:
            return dict(self.counts)

    def summary(self) -> str:
        return summary_line(self.message_counts(), self.path, self.losses.lost)

    def close(self) -> None:
        """Close the bag (the MCAP summary and metadata.yaml) and say what it holds; idempotent."""
        if not self._closed:
            self._drain()
        with self._lock:
            if self._bag is None or self._said:
                return
            self._said = self._closed = True
            if self._bag.failed is None:
                try:
                    self._stamps.close(self._bag.write_many)
                    if self.clock_span:  # how far /clock ran while recording: track-summary --duration
                        for key, ns in zip(CLOCK_SPAN, self.clock_span, strict=True):
                            self._writer.set_custom_data(key, str(ns))
                    self._bag.close()
                except OSError as exc:
                    self._bag.fail(exc)
                    self.exit_code = 2
        failed = self._bag.failed is not None
        line = self._bag.failure_line(sum(self.counts.values()) + self.dropped, self.losses.total()) if failed \
            else self.summary()
        if not failed and self.p.discard_empty and not sum(self.counts.values()):
            shutil.rmtree(self.path, ignore_errors=True)
            line = f'nothing recorded: {self.path} removed (discard_empty)'
        if self.context.ok():
            (self.get_logger().error if failed else self.get_logger().info)(line)
        else:  # after shutdown the logger can no longer reach /rosout and complains
            print(f'[{"ERROR" if failed else "INFO"}] [{self.get_name()}]: {line}', file=sys.stderr)

    def destroy_node(self) -> None:
        self.close()
        super().destroy_node()


def parse_cli(argv: Sequence[str]) -> list[Parameter]:
    """Non-ROS CLI arguments → parameter overrides (``--ros-args`` are left to rclpy)."""
    ap = OneLineParser(prog='track-record', description='Record topics to bags/NAME/ (rosbag2, MCAP).')
    ap.add_argument('name', nargs='?', help="bag name (→ bags/NAME/) or a path containing '/'")
    ap.add_argument('-t', '--topics', nargs='+', default=None, metavar='TOPIC', help='topics to record')
    ap.add_argument('-e', '--regex', default=None, help='record every topic matching REGEX')
    ap.add_argument('--no-tf', dest='no_tf', action='store_true',
                    help='do not record /tf, /tf_static and /map_datum (recorded by default, whatever the filter)')
    ap.add_argument('--flush-period', type=float, default=None, metavar='S',
                    help='flush pending messages to the file every S seconds (default 1)')
    ap.add_argument('--clock', choices=MODES, default=None,
                    help='time stamps: sim time when /clock is published, else wall time (auto, the default: '
                         'decided within 2 s of the first message), sim (use_sim_time) or wall')
    overrides = cli_overrides(ap, argv, {'name': 'bag', 'topics': 'topics', 'regex': 'regex',
                                         'flush_period': 'flush_period', 'no_tf': 'tf', 'clock': 'clock'})
    return [Parameter('tf', value=False) if o.name == 'tf' else o for o in overrides]  # --no-tf: tf false


def main(argv: Sequence[str] | None = None) -> int:
    args = list(sys.argv if argv is None else argv)
    overrides = parse_cli(args)
    return run_node(RecorderNode, args, parameter_overrides=overrides or None)


if __name__ == '__main__':
    raise SystemExit(main())
