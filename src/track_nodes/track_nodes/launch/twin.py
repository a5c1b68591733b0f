"""One run per domain: the launcher looks at its domain before it publishes anything.

Two launchers given one ``ROS_DOMAIN_ID`` would share a graph. Had the second one built its
``/clock`` publisher and its nodes before it noticed the first, they would already publish into the
first run (its tracker sees time go backwards) and the first run's own check (``isolation``) would
stop it too. So before the launcher builds anything, ``probe`` puts a node of its own on the domain
that publishes nothing of a run's (no ``/clock``, no ``/rosout``; a hidden name no run uses) and
listens for up to ``TWIN_LISTEN`` wall seconds, the time a node process gives discovery for the same
question (``base/ready.py``), for

- another ``/clock`` publisher (another run, a player, ``ros2 launch``'s clock), when this run drives ``/clock``;
- one of the run's node names (the scenario's, ``recorder``, ``track_launcher``: another launcher)
  in the graph or announced on ``/track/ready``; ``TRACK_ALLOW_TWINS=1`` lets the scenario's names be.

A finding counts when two looks ``LOOK_EVERY`` apart agree (a run that is just going away stops
nothing); then the probe leaves and the launcher refuses in one line, having published nothing.
The first run never counts the probe: it has none of the run's names and no publisher on its topics.
Two launchers started within one listen of each other are still told apart by the checks of the
running graph (``_refuse_twins`` below, ``isolation.ForeignCheck``).
"""

from __future__ import annotations

import os
import time
from collections import Counter

import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node

from track_msgs_py.topics import CLOCK
from track_nodes.base.ready import ALLOW_TWINS, TWIN_LISTEN, Announced, twins_allowed
from track_nodes.launch.graph import listing

LOOK_EVERY = 0.25  # [wall s] between two looks at the graph
LAUNCHER = 'track_launcher'  # the launcher's own node (graph.LauncherNode)
UNNAMED = '_NODE_NAME_UNKNOWN_'  # rmw's name of a publisher whose node is not discovered yet


def probe(names: list[str], sim: bool, listen: float = TWIN_LISTEN) -> str | None:
    """Listen on this process's domain (its environment) for another run; the line that refuses, or None."""
    context = Context()
    rclpy.init(args=[], context=context)
    node = Node(f'_track_launch_probe_{os.getpid()}', context=context, start_parameter_services=False,
                parameter_overrides=[], enable_rosout=False, use_global_arguments=False)
    announced = Announced(node)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    deadline, suspect = time.monotonic() + listen, None
    try:
        while (left := deadline - time.monotonic()) > 0:
            found = _look(node, announced.names, names, sim)
            # a publisher seen before its node's name (discovery): look again for the name, until the deadline
            if found is not None and found == suspect and (UNNAMED not in found or left <= LOOK_EVERY):
                return _refusal(found)
            suspect = found
            until = time.monotonic() + min(left, LOOK_EVERY)
            while (wait := until - time.monotonic()) > 0:
                executor.spin_once(timeout_sec=wait)
        return None
    finally:
        executor.shutdown(timeout_sec=0)
        node.destroy_node()
        context.try_shutdown()


def _refusal(found: str) -> str:
    domain = os.environ.get('ROS_DOMAIN_ID') or '0'
    return (f'not alone in ROS_DOMAIN_ID={domain}: {found}; refusing to start (nothing published): '
            'another run or program uses this domain; unset ROS_DOMAIN_ID for a domain of its own')


def _look(node: Node, announced: set[str], names: list[str], sim: bool) -> str | None:
    if sim and (infos := node.get_publishers_info_by_topic(CLOCK)):
        others = sorted({f'{i.node_namespace.rstrip("/")}/{i.node_name}' for i in infos})
        return f'{len(infos)} other /clock publisher(s) in this ROS domain (nodes: {", ".join(others)})'
    ours = [LAUNCHER] + ([] if twins_allowed() else list(names))
    graph = {name for name, ns in node.get_node_names_and_namespaces() if ns == '/'}
    if here := [n for n in ours if n in graph or f'/{n}' in announced]:
        what = 'another launcher' if LAUNCHER in here else 'node(s) of this run'
        return f'{what} already here ({listing(here)})'
    return None


def refuse_twins(launcher, names: list[str]) -> str | None:
    """One process, while it comes up: a node of another process announced one of our names first, or the
    graph holds one of our names twice (participant discovery can come before the announcement): the line."""
    if twins_allowed():
        return None
    if twins := launcher.foreign_twins(names):
        return f'{listing(twins)}: refusing to run a second node of that name (set {ALLOW_TWINS}=1 to allow it)'
    seen = Counter(name for name, ns in launcher.get_node_names_and_namespaces() if ns == '/')
    if twice := [n for n in names if seen[n] > 1]:
        return (f'{listing(twice)} already run(s) in this ROS domain: refusing to run a second node '
                f'of that name (set {ALLOW_TWINS}=1 to allow it)')
    return None
