"""``node_group``: several nodes of this package set in one process, on one executor.

Usage::

    node_group --nodes EXECUTABLE[:NAME] [EXECUTABLE[:NAME] ...] --ros-args --params-file FILE ...

A sensor field of 40 IDSQ nodes started as 40 processes imports numpy/scipy 40 times and does not
come up on a 2-core machine in minutes; in one process the nodes share one interpreter and one
executor, and each is still a full ROS node (own name, parameters, topics, ``ros2 node info``).
``ros2 launch`` files start the IDSQ field this way by default (``launch/ros2_launch.py``); one
process per sensor stays available for real deployments. The ``--ros-args`` apply to every node of
the group (a params file addresses each by name; do not give ``__node:=``, it would rename them
all). A bad parameter of any node stops the whole group with one line, exit code 2.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence

from track_nodes.base.cli import OneLineParser
from track_nodes.base.run import EXIT_BAD_INPUT, run_nodes
from track_nodes.registry import NODES, node_class


def parse_entries(entries: Sequence[str]) -> list[tuple[str, str | None]]:
    """``'exe[:name]'`` entries → (executable, node name or None for its default); ValueError names a bad one."""
    out = []
    for entry in entries:
        exe, _, name = entry.partition(':')
        if exe not in NODES:
            raise ValueError(f'--nodes {entry}: unknown executable {exe!r}; known: {", ".join(sorted(NODES))}')
        out.append((exe, name or None))
    names = [name or node_class(exe).DEFAULT_NAME for exe, name in out]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ValueError(f'--nodes: node names repeated: {", ".join(dup)} (give each a :NAME)')
    return out


def main(argv: Sequence[str] | None = None) -> int:
    from rclpy.utilities import remove_ros_args

    args = list(sys.argv if argv is None else argv)
    ap = OneLineParser(prog='node_group', description='several nodes in one process')
    ap.add_argument('--nodes', nargs='+', required=True, metavar='EXE[:NAME]')
    opts = ap.parse_args(remove_ros_args(args)[1:])
    try:
        entries = parse_entries(opts.nodes)
    except ValueError as exc:
        print(f'node_group: {exc}', file=sys.stderr)
        return EXIT_BAD_INPUT
    makers = [(name or exe, lambda exe=exe, name=name: node_class(exe)(node_name=name)) for exe, name in entries]
    return run_nodes(makers, args, program='node_group')  # rcl reads only the --ros-args part
