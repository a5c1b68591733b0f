"""Unknown parameter names refused: a typo such as ``-p perod:=0.5`` stops the node, not runs it on defaults.

rclpy keeps every override that reaches a node (``-p``, ``--params-file``, ``parameter_overrides``) and
silently ignores the ones the node never declares. ``CheckedNames``, the metaclass of ``TrackNode``,
looks once the node is fully built (its ``Params``, ``setup`` and any declaration after it, such as
the ``<prefix>.*`` of a ``group``), and an override that was addressed to THIS node but names no declared
parameter is refused with one line and the closest declared names (``difflib``).

Addressed to this node means: a ``parameter_overrides`` entry, a ``-p name:=value`` (or
``-p node:name:=value`` with this node's name), or a key under a params-file section that names this
node (``node:``, ``/node:``, ``/ns/node:``, nested ``ns: node:``, or ``/**/node:``, the form our
scenario files use so that they apply in any namespace). Keys under the other wildcard sections
(``/**:``, ``/ns/*:``) are shared by nodes that declare different sets, so they are not refused here
(``shared_names_problem`` checks ``/**`` against all the nodes of a run that holds them all);
sections for other nodes never reach this node. rclpy's own parameters (``use_sim_time``,
``start_type_description_service``, ``qos_overrides./topic...``) are valid.
A ``-p name:=value`` without a node prefix is addressed to every node of the process, so in a
``node_group`` give a parameter that only some nodes have as ``-p NODE:name:=value`` (or in a section).

The process-wide ``--ros-args`` are not kept by rclpy; ``remember_args(context, args)`` records them
where the context is initialised (``run_nodes``, the launcher), so their params files can be read.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any

from track_core.names import unknown_line

RCLPY_OWN = ('use_sim_time', 'start_type_description_service')
RCLPY_PREFIXES = ('qos_overrides.',)  # rclpy's QoS overrides, declared only for endpoints that allow them


def remember_args(context: Any, args: Sequence[str] | None) -> None:
    """Record the arguments ``context`` was initialised with (rclpy keeps none)."""
    context.track_args = list(args or ())


def _flatten(params: Any, prefix: str = '') -> list[str]:
    """``ros__parameters`` mapping → parameter names (nested mappings give dotted names, as rcl does)."""
    if not isinstance(params, dict):
        return [prefix[:-1]] if prefix else []
    out = []
    for key, value in params.items():
        out += _flatten(value, f'{prefix}{key}.') if isinstance(value, dict) else [f'{prefix}{key}']
    return out


def file_sections(doc: Any, path: str = '') -> list[tuple[str, list[str]]]:
    """A params-file document → (section as a fully qualified pattern, parameter names) for each
    ``ros__parameters`` block, with nested namespaces joined (``ns: node:`` → ``/ns/node``)."""
    if not isinstance(doc, dict):
        return []
    out = []
    for key, value in doc.items():
        if key == 'ros__parameters':
            out.append((path or '/', _flatten(value)))
        elif isinstance(value, dict):
            out += file_sections(value, f'{path}/{str(key).strip("/")}')
    return out


def _sections_of(path: str) -> list[tuple[str, list[str]]]:
    """``file_sections`` of the params file ``path``; none when it cannot be read (an unreadable file
    is refused before any node is built: ``cli.params_file_problem``)."""
    import yaml

    try:
        with open(path, encoding='utf-8') as f:
            return file_sections(yaml.safe_load(f))
    except (OSError, yaml.YAMLError):
        return []


def ros_options(args: Sequence[str]) -> list[tuple[str, str]]:
    """(option, value) pairs of the ``--ros-args ... [--]`` parts of ``args`` (rcl reads only those)."""
    out, in_ros = [], False
    for i, a in enumerate(args):
        if a == '--ros-args':
            in_ros = True
        elif a == '--':
            in_ros = False
        elif in_ros and a.startswith('-') and i + 1 < len(args):
            out.append((a, args[i + 1]))
    return out


def _dash_p(options: list[tuple[str, str]], node_name: str) -> set[str]:
    """Names set by ``-p``/``--param`` for every node or for ``node_name`` (``-p node:name:=value``)."""
    names = set()
    for opt, value in options:
        if opt in ('-p', '--param'):
            target, _, name = value.partition(':=')[0].rpartition(':')
            if target in ('', node_name):
                names.add(name)
    return names


def addressed_names(node: Any, args: Sequence[str], overrides: Iterable[str]) -> set[str]:
    """Parameter names that ``args`` (``--ros-args`` style) and ``overrides`` address to ``node`` itself."""
    fqn, name = node.get_fully_qualified_name(), node.get_name()
    own = (fqn, f'/**/{name}')
    options = ros_options(args)
    names = set(overrides) | _dash_p(options, name)
    for path in (value for opt, value in options if opt == '--params-file'):
        names.update(k for section, keys in _sections_of(path) if section in own for k in keys)
    return names


def undeclared_problem(node: Any, args: Sequence[str], overrides: Iterable[str]) -> str | None:
    """One line naming every override addressed to ``node`` that it did not declare, or None."""
    reached = set(getattr(node, '_parameter_overrides', {}))  # what rcl and the constructor gave this node
    declared = set(node._parameters)
    unknown = {n for n in addressed_names(node, args, overrides) & reached
               if n not in declared and n not in RCLPY_OWN and not n.startswith(RCLPY_PREFIXES)}
    if not unknown:
        return None
    return unknown_line('parameter' + ('s' if len(unknown) > 1 else ''), unknown, declared,
                        f' for node {node.get_fully_qualified_name()}', known='declared')


def shared_names_problem(nodes: Sequence[Any], params_files: Sequence[str]) -> str | None:
    """One line naming the keys under ``/**`` of ``params_files`` that no node of ``nodes`` declares, or
    None: for a process that holds every node those files are for (the launcher's one-process run)."""
    declared = {name for node in nodes for name in node._parameters}
    unknown = {k for path in params_files for section, keys in _sections_of(path) if section == '/**'
               for k in keys if k not in declared and k not in RCLPY_OWN and not k.startswith(RCLPY_PREFIXES)}
    if not unknown:
        return None
    return unknown_line('parameter' + ('s' if len(unknown) > 1 else ''), unknown, declared,
                        ' under /** (no node of the run declares it)', known='declared')


class CheckedNames(type):
    """Metaclass: once a node is fully constructed, an undeclared parameter addressed to it is refused
    (``ParameterError``, one line; the node is destroyed first)."""

    def __call__(cls, *args: Any, **kwargs: Any) -> Any:
        from track_nodes.base.params import ParameterError

        node = super().__call__(*args, **kwargs)
        own = list(kwargs.get('cli_args') or ())
        given = [*getattr(node.context, 'track_args', ()), '--', *own] if kwargs.get('use_global_arguments', True) \
            else own
        problem = undeclared_problem(node, given, [p.name for p in kwargs.get('parameter_overrides') or ()])
        if problem is not None:
            node.destroy_node()
            raise ParameterError(problem)
        return node
