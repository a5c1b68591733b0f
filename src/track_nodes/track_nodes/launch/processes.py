"""``--processes`` mode: one OS process per node, each in its own process group.

With ``hosts`` (``--hosts N``) node k runs in simulated host k mod N (``ip netns exec``); the
recorder stays in the launcher's namespace, which reaches every host (see ``hosts``).

A terminal Ctrl-C then reaches only the launcher, which stops the children in order (SIGINT,
then a kill after 10 s) so the recorder closes its bag.
"""

from __future__ import annotations

import signal
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path

from track_nodes.launch.hosts import Hosts
from track_nodes.launch.scenario import NodeSpec


def spawn_nodes(specs: Sequence[NodeSpec], params_files: Sequence[str], sim: bool, bag: Path | None,
                record_regex: str, hosts: Hosts | None = None) -> list[subprocess.Popen]:
    """Start every node of ``specs`` (and the recorder when ``bag`` is set) as ``python -m track_nodes EXE``."""
    files = [a for f in params_files for a in ('--params-file', f)]
    use_sim = f'use_sim_time:={str(sim).lower()}'
    cmds = [[sys.executable, '-m', 'track_nodes', spec.executable, '--ros-args', '-r', f'__node:={spec.name}',
             *files, '-p', use_sim] for spec in specs]
    if bag is not None:
        cmds.append([sys.executable, '-m', 'track_nodes', 'recorder', '--ros-args', '-p', use_sim,
                     '-p', f'bag:={bag}', '-p', f'regex:={record_regex}'])
    labels = [spec.name for spec in specs] + ['recorder']
    env = None if hosts is None else hosts.env()
    children = []
    for k, cmd in enumerate(cmds):
        in_host = hosts is not None and k < len(specs)
        child = subprocess.Popen([*hosts.prefix(k % hosts.n), *cmd] if in_host else cmd, env=env,
                                 start_new_session=True)
        child.label = labels[k]  # type: ignore[attr-defined]
        children.append(child)
    return children


def stop_processes(children: Sequence[subprocess.Popen]) -> None:
    """SIGINT every child still running, wait up to 10 s each, then kill."""
    for child in children:
        if child.poll() is None:
            child.send_signal(signal.SIGINT)
    for child in children:
        try:
            child.wait(timeout=10)
        except subprocess.TimeoutExpired:
            print(f'track_nodes.launch: {getattr(child, "label", child.pid)} still running 10 s after SIGINT: '
                  'killed', file=sys.stderr)
            child.kill()
            child.wait()
