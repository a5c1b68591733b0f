"""What the launcher checks before it builds anything: its ``--params`` files and its ``--record`` place.

Each is refused in one line (the launcher's ``LaunchError``), before a node, a process or a bag exists:

- a ``--params`` file that is missing, not UTF-8, not valid YAML or not a mapping (``base.cli``'s
  check; rcl would raise from ``rclpy.init``), or whose sections name no node of the scenario;
- a value whose type differs from the one an earlier layer (the scenario, then each earlier
  ``--params``) gives the same parameter in the same section: rcl merges the two into one entry that
  holds both, and rclpy reads the first type of bool, integer, double, string (then the arrays), so
  ``period: "abc"`` over ``period: 0.1`` was dropped silently while the same file alone is refused;
- a ``--record`` place whose directory cannot be made (a file in the way), is not writable (``/proc``),
  or whose file system has less free than the recorder's reserve (``bag.durable.RESERVE_MIN``) plus
  ``BAG_MARGIN``: a disk full at start, which left a 43-byte .mcap.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import yaml

from track_nodes.bag.durable import RESERVE_MIN
from track_nodes.base.cli import params_file_problem
from track_nodes.launch.scenario import Scenario, params_file_sections

BAG_MARGIN = 256 * 1024  # [bytes] beyond the reserve: the MCAP header, the first chunk, metadata.yaml


def params_problem(files: list[Path], scenario: Scenario) -> str | None:
    """Why the ``--params`` ``files`` (in their order, over the scenario) cannot be used, or None."""
    layers = [(scenario.path, _values(_load(scenario.path)))]
    for path in files:
        if not path.is_file():
            return f'--params {path}: no such file'
        try:
            problem = params_file_problem(['--ros-args', '--params-file', str(path)])
        except ValueError as exc:  # not UTF-8
            problem = f'--params-file {path}: not a text file ({exc.reason} at byte {exc.start})'
        if problem is not None or (problem := params_file_sections(path, scenario)) is not None:
            return problem.replace('--params-file', '--params', 1)
        values = _values(_load(path))
        if (problem := _type_problem(path, values, layers)) is not None:
            return problem
        layers.append((path, values))
    return None


def _type_problem(path: Path, values: dict, layers: list[tuple[Path, dict]]) -> str | None:
    """A value of ``values`` (the layer ``path``) whose type is not the one of the nearest layer below that sets it."""
    for key, value in values.items():
        below, earlier = next(((p, v[key]) for p, v in reversed(layers) if key in v), (None, None))
        if earlier is None:
            continue
        if (was := _rcl_type(earlier)) != (now := _rcl_type(value)) and None not in (was, now):
            return (f'--params {path}: {key[0]} {key[1]}: {_text(value)} ({now}) over {_text(earlier)} ({was}) '
                    f'of {below.name}: layers must agree on a type (rcl keeps one of the two, not always the '
                    f'last); give {"an" if was[0] in "aeiou" else "a"} {was}')
    return None


def bag_problem(bag: Path) -> str | None:
    """Why a bag cannot be started at ``bag`` (its directory, writable, room for the reserve), or None."""
    where = bag.parent
    try:
        where.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        why = 'a file is in the way' if isinstance(exc, (FileExistsError, NotADirectoryError)) else exc.strerror
        return f'--record {bag}: cannot make the directory {where}: {why}'
    try:
        with tempfile.TemporaryFile(dir=where):
            pass
        fs = os.statvfs(where)
    except OSError as exc:
        return f'--record {bag}: cannot write in {where}: {exc.strerror or exc}'
    free, need = fs.f_bavail * fs.f_frsize, RESERVE_MIN + BAG_MARGIN
    if free < need:
        return (f'--record {bag}: no room for a bag: {free // 1024} KiB free in {where} (the recorder needs '
                f'{need // 1024} KiB to start)')
    return None


def _load(path: Path) -> yaml.Node | None:
    """The YAML node tree: unlike the loaded values it tells a quoted "1.0" (a string to rcl) from a plain one."""
    with open(path, encoding='utf-8') as f:
        return yaml.compose(f, Loader=yaml.SafeLoader)


def _values(node: yaml.Node | None, section: str = '') -> dict[tuple[str, str], yaml.Node]:
    """(section, parameter) → value node of every ``ros__parameters`` block of a params document, nested
    sections and parameter namespaces joined (``ns: node:`` → ``/ns/node``; ``a: b:`` → ``a.b``)."""
    out: dict[tuple[str, str], yaml.Node] = {}
    for key, value in (node.value if isinstance(node, yaml.MappingNode) else ()):
        if key.value == 'ros__parameters':
            out.update({(section or '/', name): v for name, v in _flat(value).items()})
        elif isinstance(value, yaml.MappingNode):
            out.update(_values(value, f'{section}/{str(key.value).strip("/")}'))
    return out


def _flat(node: yaml.Node, prefix: str = '') -> dict[str, yaml.Node]:
    out: dict[str, yaml.Node] = {}
    for key, value in (node.value if isinstance(node, yaml.MappingNode) else ()):
        name = f'{prefix}{key.value}'
        out.update(_flat(value, f'{name}.') if isinstance(value, yaml.MappingNode) else {name: value})
    return out


TAGS = {'bool': 'bool', 'int': 'integer', 'float': 'double'}


def _rcl_type(node: yaml.Node) -> str | None:
    """The parameter type rcl gives a YAML value (None: no simple value, left to rcl)."""
    if isinstance(node, yaml.SequenceNode):
        first = _rcl_type(node.value[0]) if node.value else None
        return None if first is None or ' ' in first else f'{first} array'
    if not isinstance(node, yaml.ScalarNode) or node.tag.endswith(':null'):
        return None
    if node.style in ('"', "'"):
        return 'string'
    if (tag := node.tag.rsplit(':', 1)[-1]) in TAGS:
        return TAGS[tag]
    try:
        float(node.value)  # rcl reads a plain 1e3 as a double (YAML 1.1: a string)
    except ValueError:
        return 'string'
    return 'double'


def _text(node: yaml.Node) -> str:
    """A value as written."""
    if isinstance(node, yaml.SequenceNode):
        return f'[{", ".join(_text(v) for v in node.value)}]'
    quote = node.style if node.style in ('"', "'") else ''
    return f'{quote}{node.value}{quote}' if isinstance(node, yaml.ScalarNode) else '{...}'
