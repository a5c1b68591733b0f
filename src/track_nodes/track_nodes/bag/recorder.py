"""``recorder``: record topics to a rosbag2 bag (``metadata.yaml`` + MCAP, version 9).

Usage::

    track-record NAME [-t TOPIC ...] [-e REGEX] [--no-tf] [--flush-period S] [--ros-args ...]
    .venv/lib/track_nodes/recorder --ros-args -p bag:=NAME -p regex:=REGEX -p topics:="['/a', '/b']"

- NAME → ``bags/NAME/`` relative to the cwd, or a path if it contains '/'. An existing bag is
  never overwritten (one error line, exit 2). Without a name: ``bags/rosbag2_<timestamp>/``.
- What is recorded: the listed ``topics``, plus every topic matching ``regex`` (``re.search``).
  With neither, every topic. ``/rosout``, ``/parameter_events`` and ``/track/ready`` are only recorded when listed
  in ``topics``. The transform tree, ``/tf`` and ``/tf_static``, is recorded too whatever the
  filter (a bag whose frames cannot be placed is of little use in RViz or Foxglove), unless
  ``tf`` is false (``--no-tf``); a topic listed in ``topics`` is recorded even then. ``/tf_static``
  is transient-local, so a recorder started late still gets every static transform. Topics that
  appear later are found by polling the graph every ``discovery_period`` seconds; a topic is
  subscribed once it has a publisher (its type and QoS come from the publishers). Discovery and
  flushing run on the steady clock, also under ``use_sim_time`` (/clock may start only later).
- Subscriptions are raw (the CDR bytes are written as received). QoS
  (``bag.api.recording_qos``): best effort if any publisher is best effort, transient-local if
  all are, else reliable; keep-last 100,000 (best effort 1000), though Fast DDS holds at most
  5000 samples per reader by default, so a reliable publisher's history covers the rest of a
  burst. The publishers' offered QoS is stored in the bag.
- Losses are counted (``bag.loss.LossCounter``: gaps in the publication sequence numbers, and
  the middleware's message-lost events where several publishers share a topic), warned about
  while recording (one line per ``warn_throttle`` seconds with the count) and printed in the
  final line.
- Timestamps: the middleware's receive time (message info ``received_timestamp``, system clock),
  so a backlog keeps each message's arrival time; under ``use_sim_time`` the node's clock when
  the batch is taken (a message taken before the first /clock is written at the first reading).
- Durability: every ``flush_period`` seconds the pending MCAP chunk is written and the file
  flushed, so after a SIGKILL the .mcap holds every message up to the last flush; recover it
  with ``track-bag-recover``. SIGINT/SIGTERM (and destroying the node) close the bag cleanly.
- Throughput: a callback also takes the messages queued behind its own (``bag.take``, ≤ ``TAKE_LIMIT``)
  under one lock: 81k msgs/s in ``track-bench recorder``, 13× a bare raw subscription on the same
  executor; ``bag.take`` has the figures and the executors tried.
"""

from __future__ import annotations

import re
import sys
import threading
import time
from collections.abc import Sequence
from datetime import datetime

from rclpy.clock import Clock, ClockType
from rclpy.event_handler import SubscriptionEventCallbacks
from rclpy.parameter import Parameter

from track_msgs_py.topics import READY, TF, TF_STATIC
from track_nodes.bag.api import (
    bag_path,
    check_mcap_writer_internals,
    flush_mcap_writer,
    msg_class,
    qos_to_rosbags,
    recording_qos,
    set_ros_distro,
)
from track_nodes.bag.loss import LossCounter
from track_nodes.bag.take import BeforeClock, can_take, take_pending
from track_nodes.base import Param, TrackNode, run_node
from track_nodes.base.cli import OneLineParser, cli_overrides

EXCLUDED_BY_DEFAULT = ('/rosout', '/parameter_events', READY)  # READY: the nodes' start-up announcements
TF_TOPICS = (TF, TF_STATIC)  # recorded whatever the filter, unless tf is false
TAKE_LIMIT = 1000  # messages taken per callback beyond the one the executor delivered

PARAMS = (
    Param('bag', '', "bag name (→ bags/<name>/) or a path containing '/'; empty: rosbag2_<timestamp>"),
    Param('topics', [''], 'topics to record (empty: only those matching regex, or all)'),
    Param('regex', '', 'record every topic matching this regular expression (re.search)'),
    Param('tf', True, 'also record /tf and /tf_static when topics or regex select other topics'),
    Param('discovery_period', 0.1, 'interval between graph polls for new topics [s]', 0.01, 60.0),
    Param('flush_period', 1.0, 'interval between flushes of the pending data to the file [s]', 0.01, 3600.0),
    Param('warn_throttle', 5.0, 'at most one warning about lost messages per this many seconds [s]', 0.0, 3600.0),
)


def _normalise(topic: str) -> str:
    return topic if topic.startswith('/') else '/' + topic


class RecorderNode(TrackNode):
    DEFAULT_NAME = 'recorder'
    PARAMS = PARAMS

    def setup(self) -> None:
        self._writer = None
        self._closed = False
        self._lock = threading.Lock()
        self._before_clock = BeforeClock()
        self._clock = self.get_clock()
        self._batching = True  # until a subscription lacks take_message (bag.take.can_take)
        p = self.p
        self.explicit = {_normalise(t) for t in p.topics if t}
        try:
            self.regex = re.compile(p.regex) if p.regex else None
        except re.error as exc:
            raise ValueError(f'parameter regex={p.regex!r} is not a valid regular expression: {exc}') from None
        if self.regex is None and not self.explicit:
            self.regex = re.compile('')  # everything
        name = p.bag or f'rosbag2_{datetime.now():%Y_%m_%d-%H_%M_%S}'
        self.path = bag_path(name)
        if self.path.exists():
            raise ValueError(f'{self.path}: bag exists already, not overwriting (choose another name)')

        from rosbags.rosbag2 import StoragePlugin, Writer, WriterError
        from rosbags.typesys import Stores, get_typestore

        self.typestore = get_typestore(Stores.ROS2_JAZZY)
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            writer = Writer(self.path, version=9, storage_plugin=StoragePlugin.MCAP)
            writer.open()
        except WriterError as exc:
            raise ValueError(f'{self.path}: cannot create bag: {exc}') from None
        self._writer = writer
        try:
            check_mcap_writer_internals(writer)
        except RuntimeError:
            self._abort()
            raise
        flush_mcap_writer(writer)  # the MCAP header reaches the file at once
        self.connections: dict[str, object] = {}
        self.counts: dict[str, int] = {}
        self.subscriptions_by_topic: dict[str, object] = {}
        self.skipped: set[str] = set()
        self.losses = LossCounter()
        # Wall-clock (steady) timers: under use_sim_time, /clock may only start once we subscribed.
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.discovery_timer = self.create_timer(p.discovery_period, self.discover, clock=steady)
        self.flush_timer = self.create_timer(p.flush_period, self.flush, clock=steady)
        what = []
        if self.explicit:
            what.append('topics ' + ', '.join(sorted(self.explicit)))
        if self.regex is not None:
            what.append(f'topics matching {self.regex.pattern!r}' if self.regex.pattern else 'all topics')
        what.append('/tf and /tf_static' if p.tf else 'not /tf or /tf_static')
        self.get_logger().info(f'recording {" and ".join(what)} to {self.path}')

    # -- discovery ------------------------------------------------------------------------
    def wanted(self, topic: str) -> bool:
        if topic in self.explicit:
            return True
        if topic in TF_TOPICS:
            return self.p.tf
        if topic in EXCLUDED_BY_DEFAULT or self.regex is None:
            return False
        return self.regex.search(topic) is not None

    def discover(self) -> None:
        if self._closed:
            return
        for topic, types in self.get_topic_names_and_types():
            if topic in self.subscriptions_by_topic:
                with self._lock:
                    self.losses.publishers(topic, self.count_publishers(topic))
                continue
            if topic in self.skipped or not self.wanted(topic):
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
            batch += take_pending(sub, TAKE_LIMIT)  # the messages queued behind this one (bag.take)
        sim = self._clock.ros_time_is_active  # sim time: one clock reading for the batch
        now = self._clock.now().nanoseconds if sim else 0
        lost = 0
        with self._lock:
            if self._closed:
                return
            conn, write, received = self.connections[topic], self._writer.write, self.losses.received
            if sim and now == 0:  # before the first /clock: written at its first reading (bag.take.BeforeClock)
                self._before_clock.hold(conn, [raw for raw, _ in batch])
            else:
                self._before_clock.release(write, now)
                for raw, inf in batch:
                    write(conn, now if sim else inf.get('received_timestamp') or time.time_ns(), raw)
            for _, inf in batch:
                lost += received(topic, inf.get('publication_sequence_number'))
            self.counts[topic] += len(batch)
        if lost:
            self._warn_lost(topic)

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
            if not self._closed and self._writer is not None:
                flush_mcap_writer(self._writer)

    def message_counts(self) -> dict[str, int]:
        with self._lock:
            return dict(self.counts)

    def summary(self) -> str:
        counts = self.message_counts()
        per_topic = ', '.join(f'{t}: {n}' for t, n in sorted(counts.items())) or 'no topics'
        lost = self.losses.total()
        loss = f'; LOST {lost} ({", ".join(f"{t}: {n}" for t, n in sorted(self.losses.lost.items()) if n)})' \
            if lost else '; lost 0'
        return f'recorded {sum(counts.values())} messages ({per_topic}) to {self.path}{loss}'

    def close(self) -> None:
        """Close the bag (writes the MCAP summary and metadata.yaml); idempotent."""
        with self._lock:
            closed, self._closed = self._closed, True
            if closed or self._writer is None:
                return
            self._before_clock.release(self._writer.write, 0)  # the clock never started: log time 0
            self._writer.close()
            set_ros_distro(self.path)
        line = self.summary()
        if self.context.ok():
            self.get_logger().info(line)
        else:  # after shutdown the logger can no longer reach /rosout and complains
            print(f'[INFO] [{self.get_name()}]: {line}', file=sys.stderr)

    def _abort(self) -> None:
        self._closed = True
        if self._writer is not None:
            self._writer.abort()

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
                    help='do not record /tf and /tf_static (recorded by default, whatever the filter)')
    ap.add_argument('--flush-period', type=float, default=None, metavar='S',
                    help='flush pending messages to the file every S seconds (default 1)')
    overrides = cli_overrides(ap, argv, {'name': 'bag', 'topics': 'topics', 'regex': 'regex',
                                         'flush_period': 'flush_period', 'no_tf': 'tf'})
    return [Parameter('tf', value=False) if o.name == 'tf' else o for o in overrides]  # --no-tf: tf false


def main(argv: Sequence[str] | None = None) -> int:
    args = list(sys.argv if argv is None else argv)
    overrides = parse_cli(args)
    return run_node(RecorderNode, args, parameter_overrides=overrides or None)


if __name__ == '__main__':
    raise SystemExit(main())
