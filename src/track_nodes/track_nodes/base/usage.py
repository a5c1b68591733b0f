"""``--help`` of a node executable: what the node does, how to run it, every parameter with its default.

Asked before ``--ros-args`` (``ros2 run track_nodes fusion --help``), it prints and exits 0 without
rclpy or DDS: nothing joins the graph. The parameter list is the one the node declares
(``base/params.all_specs``), so ``ros2 param describe`` on a running node says the same.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence

from track_nodes.base.params import all_specs

HELP_FLAGS = ('-h', '--help')


def wants_help(args: Sequence[str]) -> bool:
    """True when ``-h``/``--help`` comes before ``--ros-args`` (after it, the words are rcl's)."""
    args = list(args)
    own = args[:args.index('--ros-args')] if '--ros-args' in args else args
    return any(a in HELP_FLAGS for a in own[1:])


def usage(executable: str, cls: type) -> str:
    """The help text of the node class ``cls`` run as ``executable``."""
    doc = (cls.__doc__ or '').strip() or (sys.modules[cls.__module__].__doc__ or '').strip()
    doc = doc.split('\n\n')[0]
    lines = [f'usage: ros2 run track_nodes {executable} [--ros-args [-r __node:=NAME] [-r __ns:=/NS] '
             '[-p NAME:=VALUE] [--params-file FILE]]',
             f'   or: python -m track_nodes {executable} [--ros-args ...]', '',
             ' '.join(doc.split()), '',
             f'node name: {cls.DEFAULT_NAME} (by default)']
    specs = all_specs(cls.Params)
    if not specs:
        lines.append('parameters: none of its own (use_sim_time and the ROS ones)')
        return '\n'.join(lines)
    lines.append('parameters (name = default; allowed; live: settable with ros2 param set):')
    for s in specs:
        bounded = s.choices is not None or s.lo is not None or s.hi is not None
        allowed = s.allowed() if bounded else type(s.default).__name__
        lines.append(f"  {s.name} = {s.default!r}  ({allowed}; {'live' if s.live else 'read-only'})  {s.description}")
    return '\n'.join(lines)
