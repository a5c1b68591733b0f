"""Command-line parsing shared by the nodes and the bag tools."""

from __future__ import annotations

import argparse
from collections.abc import Mapping, Sequence


class OneLineParser(argparse.ArgumentParser):
    """argparse whose errors are one line on stderr and exit code 2 (no usage block)."""

    def error(self, message: str):
        self.exit(2, f'{self.prog}: {message}\n')


def cli_overrides(ap: argparse.ArgumentParser, argv: Sequence[str], params: Mapping[str, str]) -> list:
    """Parse ``argv`` (sys.argv-style; ``--ros-args`` are left to rclpy) and return parameter overrides.

    ``params`` maps an argument's ``dest`` to the node parameter it sets; arguments not given
    (``None``, or ``False`` for a flag) set nothing, so the node's declared defaults apply.
    """
    from rclpy.parameter import Parameter
    from rclpy.utilities import remove_ros_args

    args = ap.parse_args(remove_ros_args(list(argv))[1:])
    overrides = []
    for dest, name in params.items():
        value = getattr(args, dest)
        if value is None or value is False:
            continue
        overrides.append(Parameter(name, value=list(value) if isinstance(value, list | tuple) else value))
    return overrides


def params_file_problem(argv: Sequence[str]) -> str | None:
    """Why a ``--params-file`` of ``argv``'s ``--ros-args`` cannot be read, or ``None``.

    rcl would refuse it too, but with a Python traceback and an extra line of its own; checked
    first, a missing, unreadable or malformed file gets one line and exit code 2 like other bad input.
    """
    import yaml

    in_ros, args = False, list(argv)
    for i, arg in enumerate(args):
        if arg == '--ros-args':
            in_ros = True
        elif arg == '--':
            in_ros = False
        elif in_ros and arg == '--params-file':
            if i + 1 >= len(args):
                return '--params-file: a path is missing after it'
            path = args[i + 1]
            try:
                with open(path, encoding='utf-8') as f:
                    data = yaml.safe_load(f)
            except OSError as exc:
                return f'--params-file {path}: {exc.strerror or exc}'
            except yaml.YAMLError as exc:
                mark = getattr(exc, 'problem_mark', None)
                where = f' (line {mark.line + 1}, column {mark.column + 1})' if mark is not None else ''
                problem = getattr(exc, 'problem', None) or str(exc).splitlines()[0]
                return f'--params-file {path}: not valid YAML{where}: {problem}'
            if data is not None and not isinstance(data, dict):
                return f'--params-file {path}: expected a mapping of node names to ros__parameters'
    return None
