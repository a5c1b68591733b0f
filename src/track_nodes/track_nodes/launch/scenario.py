"""Scenario files: ``config/<scenario>.yaml`` in the ``node_name: ros__parameters:`` layout.

One extra top-level entry, ``track_launch``, belongs to no node and tells the launcher what to
run (``nodes: [executable[:node_name], ...]``) and its defaults (``LAUNCH_OPTIONS``). Because it
has the same layout, the whole file stays a valid ``--params-file`` for every node and for
``ros2 launch``.

Names are checked, since rcl gives a section that names no node to nobody: a ``track_launch`` option
or a node section (``name:``, ``/name:`` or ``/**/name:``) that is not the scenario's is refused in one
line with the closest valid names. Our files write ``/**/name:`` so that they still apply when a user
runs a node in a namespace (``-r __ns:=/robot1 --params-file config/demo.yaml``). Other wildcard
sections (``/**:``) are for every node; the keys under a node's own section are checked by the node
itself (``base/names.py``).
"""

from __future__ import annotations

import os
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from track_core.names import unknown_line
from track_nodes.base.names import file_sections
from track_nodes.registry import UnknownExecutableError
from track_nodes.registry import node_class as registered_class

LAUNCH_KEY = 'track_launch'
#: The ``track_launch`` options: name → what it sets (the launcher's command line overrides the last two).
LAUNCH_OPTIONS = {
    'nodes': 'the nodes to run, executable[:node_name]',
    'record_regex': 'topics --record writes (regular expression)',
    'summary': 'the summary printed after a recorded run (report.summary)',
    'duration': 'run length [s of node time]',
    'rate': 'lock-step clock rate (x real time; 0 = wall time)',
}
RECORDER = 'recorder'  # the node the launcher adds for --record


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
        doc = yaml.safe_load(path.read_text(encoding='utf-8'))
    except (OSError, ValueError, yaml.YAMLError) as exc:  # ValueError: not UTF-8 (a binary file)
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
    unknown = set(opts) - set(LAUNCH_OPTIONS)
    if unknown:
        raise ScenarioError(f'{path}: {unknown_line(LAUNCH_KEY + " option", unknown, LAUNCH_OPTIONS)}')
    problem = section_problem(doc, names)
    if problem is not None:
        raise ScenarioError(f'{path}: {problem}')
    return Scenario(path.stem, path, nodes, opts)


def section_problem(doc: Any, names: list[str]) -> str | None:
    """Why a params document has a section (``node``, ``/node``, ``/**/node``) for no node of ``names``
    (nor the recorder), or None."""
    valid = {f'/{n}' for n in [*names, RECORDER]}
    unknown = set()
    for section, _ in file_sections(doc):
        named = section[3:] if section.startswith('/**/') else section  # /**/node names one node
        if '*' not in named and named not in (f'/{LAUNCH_KEY}', *valid):
            unknown.add(named.lstrip('/'))
    if not unknown:
        return None
    return unknown_line('node section' + ('s' if len(unknown) > 1 else ''), unknown, [*names, RECORDER],
                        known="the scenario's nodes")


def params_file_sections(path: Path, scenario: Scenario) -> str | None:
    """``section_problem`` of an extra params file for ``scenario`` (launcher ``--params``), or None."""
    try:
        doc = yaml.safe_load(Path(path).read_text())
    except (OSError, yaml.YAMLError):
        return None  # the nodes refuse an unreadable file themselves (base/cli.params_file_problem)
    problem = section_problem(doc, [n.name for n in scenario.nodes])
    return None if problem is None else f'--params {path}: {problem}'
