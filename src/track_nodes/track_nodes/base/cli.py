"""Command-line parsing shared by the bag tools."""

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
