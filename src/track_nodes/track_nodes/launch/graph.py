"""The launcher's own node: publishes /clock and watches the graph (who is up, what is recorded, what still flows).

Who is up comes from the nodes' own announcements on ``/track/ready`` (``track_nodes.base.ready``):
transient-local, so every node alive is heard however late the launcher looks, and at any scale,
where the graph's node names (one Fast DDS ``ros_discovery_info`` sample per participant) missed
some of 65 processes over 5 hosts for minutes.
"""

from __future__ import annotations

import os
import re
import socket
import time
from collections import Counter

from diagnostic_msgs.msg import DiagnosticStatus
from rclpy.context import Context
from rclpy.node import Node
from rosgraph_msgs.msg import Clock

from track_msgs_py.qos import CLOCK_QOS
from track_msgs_py.records import RecordError
from track_msgs_py.records.ready import NodeReady
from track_msgs_py.stamps import ns_to_stamp
from track_msgs_py.topics import CLOCK, READY, TF, TF_STATIC
from track_nodes.bag.api import msg_class, recording_qos
from track_nodes.base.ready import WATCH_QOS
from track_nodes.launch.pacing import header_stamp_ns
from track_nodes.launch.tuning import READY_PER_NODE, READY_PER_PROCESS, READY_TIMEOUT

IGNORED_TOPICS = ('/rosout', '/parameter_events', CLOCK, READY)
LISTED = 8  # names given in the line of a deadline that ran out


class GraphWatch:
    """What a /clock driver needs of the graph (a mixin of a Node): its /clock publisher, who is up, what
    is recorded, what still flows. Call ``watch_graph()`` once the node is built."""

    def watch_graph(self) -> None:
        self.clock_pub = self.create_publisher(Clock, CLOCK, CLOCK_QOS)
        self.watched: dict[str, object] = {}
        self.last_message = time.monotonic()
        self.announced: dict[str, dict[tuple, NodeReady]] = {}  # fully qualified name -> its announcements
        self.create_subscription(DiagnosticStatus, READY, self._announced, WATCH_QOS)

    def _announced(self, status: DiagnosticStatus) -> None:
        try:
            rec = NodeReady.from_msg(status)
        except RecordError as exc:
            self.get_logger().warning(f'{READY}: announcement ignored: {exc}')
            return
        self.announced.setdefault(rec.name, {})[rec.order] = rec

    def watch(self, regex: str) -> None:
        """Subscribe (raw, no decoding) to every published topic matching ``regex``, to see when work ends."""
        pattern = re.compile(regex)
        for topic, types in self.get_topic_names_and_types():
            if topic in self.watched or topic in IGNORED_TOPICS or not pattern.search(topic):
                continue
            infos = self.get_publishers_info_by_topic(topic)
            if not infos:
                continue
            try:
                cls = msg_class(types[0])
            except (ValueError, KeyError):
                continue
            stamped = next(iter(cls.get_fields_and_field_types().items()), None) == ('header', 'std_msgs/Header')
            self.watched[topic] = self.create_subscription(
                cls, topic, lambda data, topic=topic, stamped=stamped: self._seen(data, topic if stamped else None),
                recording_qos([i.qos_profile for i in infos]), raw=True)

    def _seen(self, data: bytes, topic: str | None = None) -> None:
        self.last_message = time.monotonic()
        cadence = getattr(self, 'cadence', None)
        if cadence is not None and topic is not None and (t := header_stamp_ns(data)) is not None:
            cadence.seen(topic, t)

    def publish_clock(self, t_ns: int) -> None:
        self.clock_pub.publish(Clock(clock=ns_to_stamp(t_ns)))

    def clock_unmatched(self) -> int:
        """How many of the graph's /clock subscriptions our publisher has not matched yet."""
        known = [i for i in self.get_subscriptions_info_by_topic(CLOCK) if i.node_name != self.get_name()]
        return max(0, len(known) - self.clock_pub.get_subscription_count())

    def foreign(self, names: list[str], own: dict[str, int] | None, sim: bool) -> str | None:
        """What in this domain is not the run's (one line), or None (see ``isolation``).

        ``names``: the run's node names; ``own``: how many publishers the run's own nodes have per
        topic (in one process), or None where the launcher cannot count them (``--processes``).
        """
        if sim and (n := self.count_publishers(CLOCK)) > 1:
            others = sorted({f'{i.node_namespace.rstrip("/")}/{i.node_name}'
                             for i in self.get_publishers_info_by_topic(CLOCK)})
            return f'{n - 1} other /clock publisher(s) in this ROS domain (nodes: {", ".join(others)})'
        seen = Counter(name for name, ns in self.get_node_names_and_namespaces() if ns == '/')
        if twice := [n for n in names if seen[n] > 1]:
            return f'{len(twice)} node name(s) of this run twice in this ROS domain (e.g. {twice[0]})'
        for topic, n_own in sorted((own or {}).items()):
            if topic not in IGNORED_TOPICS and (n := self.count_publishers(topic)) > n_own:
                return f'{n - n_own} publisher(s) on {topic} that are not this run\'s'
        return None

    def nodes_missing(self, names: list[str]) -> list[str]:
        """The ``names`` (relative to the root namespace, or fully qualified) with no announcement yet."""
        return [n for n in names if _qualified(n) not in self.announced]

    def foreign_twins(self, names: list[str]) -> list[str]:
        """Per name of ``names`` that this process's node holds and a node of another process announced
        first (``NodeReady.newer``): what runs there."""
        here = (socket.gethostname(), os.getpid())
        lines = []
        for n in names:
            recs = sorted(self.announced.get(_qualified(n), {}).values(), key=lambda r: r.order)
            if any((r.host, r.pid) == here for r in recs) and (recs[0].host, recs[0].pid) != here:
                lines.append(f'{recs[0].name} already runs ({recs[0].where()})')
        return lines

    def topics_unrecorded(self, regex: str, recorder: str) -> list[str]:
        pattern = re.compile(regex)
        missing = []
        for topic, _ in self.get_topic_names_and_types():
            recorded = pattern.search(topic) or topic in (TF, TF_STATIC)  # the recorder's tf default
            if topic in IGNORED_TOPICS or not recorded or not self.count_publishers(topic):
                continue
            subs = {info.node_name for info in self.get_subscriptions_info_by_topic(topic)}
            if recorder not in subs:
                missing.append(topic)
        return missing



class LauncherNode(GraphWatch, Node):
    """The launcher's node: publishes /clock and watches the graph. Always on wall time."""

    def __init__(self, context: Context) -> None:
        super().__init__('track_launcher', context=context, start_parameter_services=False)
        self.watch_graph()

def _qualified(name: str) -> str:
    return name if name.startswith('/') else f'/{name}'


def ready_deadline(n_nodes: int, processes: bool) -> tuple[float, str]:
    """The ready deadline [wall s] for ``n_nodes`` nodes, and how it was derived (for the line that says it ran out)."""
    per, where = (READY_PER_PROCESS, 'process') if processes else (READY_PER_NODE, 'node in one process')
    return READY_TIMEOUT + per * n_nodes, f'the deadline for {n_nodes}: {READY_TIMEOUT:g} s + {per:g} s per {where}'


def listing(items: list[str]) -> str:
    """The first ``LISTED`` of ``items``, joined, with how many more there are."""
    more = len(items) - LISTED
    return ', '.join(items[:LISTED]) + (f' and {more} more' if more > 0 else '')
