"""Readiness and one node per name, both from the announcements on ``/track/ready``.

Every ``TrackNode`` announces itself once it has built its endpoints: one ``DiagnosticStatus``
(``track_msgs_py.records.ready.NodeReady``: fully qualified name, pid, host, start time, executable)
on ``/track/ready``, reliable and transient-local with depth 1 per node, so whoever joins later (the
launcher, a twin) still receives the announcement of every node alive, and an announcement goes
away with its node. The launcher waits for these (``launch/graph.py``) instead of reading the graph's
node names, which Fast DDS builds from one ``ros_discovery_info`` sample per participant and which
did not list every node of 65 processes over 5 hosts while all their topics had matched.

One node per name (``TRACK_ALLOW_TWINS=1`` in the environment turns both checks off):

- In one process, a node whose fully qualified name another live node of the same context holds is
  refused in its constructor (``claim``: ValueError, so one line and exit 2 from ``run_nodes``, a
  one-line error from the launcher).
- Across processes, ``run_nodes`` holds its nodes back: it listens on ``/track/ready`` for
  ``TWIN_LISTEN`` wall seconds (``Twins.listen``) before it announces them and spins. An
  announcement of one of its names by a node that started first (``NodeReady.newer``: the earlier
  start, then host name, then pid) makes the newcomer refuse before its first callback: one line,
  exit 2. Discovery and the delivery of the older node's announcement took well under a second
  between two processes of one machine; ``TWIN_LISTEN`` leaves room for a loaded one.
- A twin heard later (two nodes started within each other's listening time, or a discovery slower
  than it, e.g. a host that joins late) is decided by the same rule, since both keep listening
  while they run: the newcomer stops at once with the same line and exit 2 (its outputs were
  doubled until then), the older one logs one warning and runs on.
"""

from __future__ import annotations

import contextlib
import os
import socket
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from types import SimpleNamespace

from diagnostic_msgs.msg import DiagnosticStatus
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from track_msgs_py.qos import STATIC_QOS
from track_msgs_py.records import RecordError
from track_msgs_py.records.ready import NodeReady
from track_msgs_py.topics import READY

ALLOW_TWINS = 'TRACK_ALLOW_TWINS'  # environment: '1' lets several nodes of one name run
TWIN_LISTEN = 3.0  # [wall s] a node process listens for an older twin this long before it announces and spins
READY_QOS = STATIC_QOS  # a node's announcement: reliable, transient-local, depth 1
# Every announcement of the graph is kept until taken (one instance: KEEP_LAST counts all writers).
WATCH_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=4096, reliability=ReliabilityPolicy.RELIABLE,
                       durability=DurabilityPolicy.TRANSIENT_LOCAL)

# ``held``: set by run_nodes: its nodes announce after the listen (Twins.listen), not in their constructor.
HOLD = SimpleNamespace(held=False)
_TAKEN: dict[tuple[int, str], NodeReady] = {}  # (id of the context, fully qualified name) -> live node here


def twins_allowed() -> bool:
    return os.environ.get(ALLOW_TWINS, '').strip().lower() in ('1', 'true', 'yes', 'on')


def _executable() -> str:
    argv = sys.argv or ['python']
    if Path(argv[0]).parent.name == 'track_nodes' and len(argv) > 1:  # python -m track_nodes EXE
        return argv[1]
    return Path(argv[0]).name


def claim(node: Node, start_ns: int) -> NodeReady:
    """Take ``node``'s name in this process (ValueError if a live node of its context holds it), create its
    announcement publisher and, unless run_nodes holds the nodes back, announce it."""
    me = NodeReady(node.get_fully_qualified_name(), os.getpid(), socket.gethostname(), int(start_ns),
                   _executable())
    key = (id(node.context), me.name)
    if key in _TAKEN and not twins_allowed():
        raise ValueError(f'a node named {me.name} already runs in this process (set {ALLOW_TWINS}=1 to allow it)')
    _TAKEN[key] = me
    node.__dict__['_ready'] = (me, node.create_publisher(DiagnosticStatus, READY, READY_QOS))
    if not HOLD.held:
        announce(node)
    return me


def announce(node: Node) -> None:
    """Publish ``node``'s announcement (made by ``claim``)."""
    me, pub = node.__dict__['_ready']
    pub.publish(me.to_msg())


def release(node: Node) -> None:
    """The node is going away: its name is free again in this process."""
    entry = node.__dict__.get('_ready')
    if entry is not None and _TAKEN.get((id(node.context), entry[0].name)) == entry[0]:
        del _TAKEN[(id(node.context), entry[0].name)]


class StoppedError(RuntimeError):
    """The process stops before its nodes ran (a newcomer twin, or Ctrl-C while it listened)."""


class Twins:
    """A node process's watch on ``/track/ready`` for older nodes with the names of its own (``run_nodes``).

    A hidden helper node of the process's context holds the subscription, so the listening can be
    spun on its own, before the process's nodes run.
    """

    def __init__(self, nodes: Sequence[Node], program: str, on_refuse: Callable[[Node], None]) -> None:
        self.mine = {n.__dict__['_ready'][0].name: n for n in nodes if '_ready' in n.__dict__}
        self.program = program
        self.on_refuse = on_refuse
        self.refused: list[str] = []
        self.warned: set[tuple] = set()
        context = nodes[0].context if nodes else None
        # Not the command line's remaps: '-r __node:=NAME' would give the watch the name of the node it guards.
        self.node = Node(f'_track_ready_{os.getpid()}', context=context, start_parameter_services=False,
                         parameter_overrides=[], enable_rosout=False, use_global_arguments=False)
        self.node.create_subscription(DiagnosticStatus, READY, self._heard, WATCH_QOS)
        self.started = time.monotonic()

    def listen(self, seconds: float = TWIN_LISTEN) -> bool:
        """Spin the watch alone for ``seconds``; True when no older twin was heard (the nodes may run)."""
        executor = SingleThreadedExecutor(context=self.node.context)
        executor.add_node(self.node)
        deadline = time.monotonic() + seconds
        try:
            while not self.refused and self.node.context.ok() and (left := deadline - time.monotonic()) > 0:
                executor.spin_once(timeout_sec=min(left, 0.1))
        except KeyboardInterrupt:  # Ctrl-C while listening: a clean stop before anything ran
            self.node.context.try_shutdown()
        finally:
            executor.remove_node(self.node)
            executor.shutdown(timeout_sec=0)
        return not self.refused

    def _heard(self, status: DiagnosticStatus) -> None:
        node = self.mine.get(status.name)
        if node is None:
            return
        try:
            other = NodeReady.from_msg(status)
        except RecordError:
            return  # not an announcement we can weigh; the name's owner is unknown
        me = node.__dict__['_ready'][0]
        if other.same_node(me) or twins_allowed():
            return
        if me.newer(other):
            after = time.monotonic() - self.started
            when = '' if after <= TWIN_LISTEN else f' (heard {after:.1f} s after it began to listen: stopping)'
            line = (f'{self.program}: {me.name} already runs ({other.where()}, started '
                    f'{(me.start_ns - other.start_ns) * 1e-9:.3f} s before this one): refusing to start a '
                    f'second node of that name{when}; set {ALLOW_TWINS}=1 to allow it')
            if line not in self.refused:
                self.refused.append(line)
                print(line, file=sys.stderr, flush=True)
                self.on_refuse(node)
        elif other.order not in self.warned:
            self.warned.add(other.order)
            node.get_logger().warning(f'a second node named {me.name} started ({other.where()}); '
                                      'it is the newcomer and refuses to run')

    def destroy(self) -> None:
        self.node.destroy_node()


def settle(nodes: Sequence[Node], program: str, exit_code: int) -> Twins:
    """run_nodes: listen for older twins (``TWIN_LISTEN``), then announce ``nodes`` unless one refused.

    A refusal, now or while the nodes run, sets the node's ``exit_code`` and shuts the context
    down, which ends ``run_nodes`` like a Ctrl-C (``StoppedError`` when it happens before they ran). The
    watch keeps listening while the nodes run.
    """
    def refuse(node: Node) -> None:
        node.exit_code = exit_code
        node.context.try_shutdown()

    twins = Twins(nodes, program, refuse)
    if not (twins.listen(0.0 if twins_allowed() else TWIN_LISTEN) and twins.node.context.ok()):
        twins.destroy()
        raise StoppedError('refused, or Ctrl-C while listening')  # the context is shut down: run_nodes stops cleanly
    for node in nodes:
        if '_ready' in node.__dict__:
            announce(node)
    return twins


UNKNOWN_NODE = '_NODE_NAME_UNKNOWN_'  # rmw's name of a node whose discovery info has not arrived


def _full_name(info) -> str:
    return f'{info.node_namespace.rstrip("/")}/{info.node_name}'


class Announced:
    """The nodes announced on ``/track/ready``, as ``node`` hears them: a player asks who is not up yet.

    A node that subscribes before it spins (a ``TrackNode`` listening for an older twin) would
    queue what a player sends meanwhile and take it late; the player waits for its announcement.
    """

    def __init__(self, node: Node) -> None:
        self.node = node
        self.names: set[str] = set()
        node.create_subscription(DiagnosticStatus, READY, self._heard, WATCH_QOS)

    def _heard(self, status: DiagnosticStatus) -> None:
        with contextlib.suppress(RecordError):  # not an announcement: no node to wait for
            self.names.add(NodeReady.from_msg(status).name)

    def unready_subscribers(self, topics: Sequence[str]) -> list[str]:
        """Subscribers of ``topics`` that announce themselves (they publish on /track/ready) and have not yet."""
        announcing = {_full_name(i) for i in self.node.get_publishers_info_by_topic(READY)}
        subscribers = {_full_name(i) for t in topics for i in self.node.get_subscriptions_info_by_topic(t)}
        # A subscription is matched before its node's name is known (one ros_discovery_info sample per
        # participant, late on a loaded machine): an unnamed one may be a TrackNode, so it is waited for.
        unnamed = {n for n in subscribers if UNKNOWN_NODE in n}
        return sorted((subscribers & announcing | unnamed) - self.names)
