"""Scenario files: ``config/<scenario>.yaml`` in the ``node_name: ros__parameters:`` layout.

One extra top-level entry, ``track_launch``, belongs to no node and tells the launcher what to
run (``nodes: [executable[:node_name], ...]``) and its defaults (``record_regex``,
``summary``, ``duration``, ``rate``). Because it has the same layout, the whole file stays a
valid ``--params-file`` for every node and for ``ros2 launch``.
"""

from __future__ import annotations

import os
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from track_nodes.registry import UnknownExecutableError
from track_nodes.registry import node_class as registered_class

LAUNCH_KEY = 'track_launch'


class ScenarioError(ValueError):
    """A scenario file is missing or malformed; the message is one line."""


@dataclass
class NodeSpec:
    executable: str
    name: str

    def node_class(self):
        """The node class of ``executable`` (``track_nodes.registry``)."""
        try:
            return registered_class(self.executable)
        except UnknownExecutableError:
            raise ScenarioError(f'unknown node executable {self.executable!r} (not in track_nodes.registry)') from None


@dataclass
class Scenario:
    name: str
    path: Path
    nodes: list[NodeSpec]
    options: dict[str, Any] = field(default_factory=dict)


def find_scenario(name: str) -> Path:
    """``name`` as a path, else ``./config/<name>.yaml``, else the installed share/track_nodes/config: of the
    prefix the ament index gives (the first on AMENT_PREFIX_PATH holding track_nodes), then of sys.prefix."""
    candidates = [Path(name)] if name.endswith(('.yaml', '.yml')) else []
    candidates.append(Path('config') / f'{name}.yaml')
    prefixes = [Path(p) for p in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep) if p]
    indexed = [p for p in prefixes if (p / 'share/ament_index/resource_index/packages/track_nodes').is_file()]
    for prefix in dict.fromkeys([*indexed[:1], Path(sys.prefix)]):
        candidates.append(prefix / 'share' / 'track_nodes' / 'config' / f'{name}.yaml')
    for cand in candidates:
        if cand.is_file():
            return cand.resolve()
    raise ScenarioError(f'scenario {name!r} not found (looked for {", ".join(str(c) for c in candidates)})')


def load_scenario(name: str) -> Scenario:
    path = find_scenario(name)
    try:
        doc = yaml.safe_load(path.read_text())
    except (OSError, yaml.YAMLError) as exc:
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise ScenarioError(f'{path}: cannot read scenario: {first}') from None
    try:
        opts = dict(doc[LAUNCH_KEY]['ros__parameters'])
        entries = list(opts.pop('nodes'))
    except (TypeError, KeyError):
        raise ScenarioError(f'{path}: needs {LAUNCH_KEY}: ros__parameters: nodes: [...]') from None
    nodes = []
    for entry in entries:
        exe, _, node_name = str(entry).partition(':')
        nodes.append(NodeSpec(exe, node_name or exe))
    names = [n.name for n in nodes]
    if len(set(names)) != len(names):
        raise ScenarioError(f'{path}: node names must be unique, got {names}')
    return Scenario(path.stem, path, nodes, opts)
