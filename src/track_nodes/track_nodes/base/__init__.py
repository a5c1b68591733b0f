"""What every node and tool of track_nodes shares: the node base, parameters, step clock, CLI parsing.

The names below are imported on first use (PEP 562), not with the package: ``--help`` of an
executable (``base.usage``) lives in this package and must answer without loading rclpy, numpy and
the node base, which take seconds on a busy machine. ``from track_nodes.base import TrackNode``
works as ever.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

_WHERE = {
    'remember_args': 'names', 'shared_names_problem': 'names', 'TrackNode': 'node', 'NoParams': 'params',
    'ParameterError': 'params', 'group': 'params', 'param': 'params', 'vector': 'params',
    'EXIT_BAD_INPUT': 'run', 'run_node': 'run', 'FixedRateSteps': 'steps',
}

__all__ = ['EXIT_BAD_INPUT', 'FixedRateSteps', 'NoParams', 'ParameterError', 'TrackNode', 'group', 'param',
           'remember_args', 'run_node', 'shared_names_problem', 'vector']

if TYPE_CHECKING:
    from track_nodes.base.names import remember_args, shared_names_problem
    from track_nodes.base.node import TrackNode
    from track_nodes.base.params import NoParams, ParameterError, group, param, vector
    from track_nodes.base.run import EXIT_BAD_INPUT, run_node
    from track_nodes.base.steps import FixedRateSteps


def __getattr__(name: str) -> Any:
    if name not in _WHERE:
        raise AttributeError(f'module {__name__!r} has no attribute {name!r}')
    value = getattr(importlib.import_module(f'{__name__}.{_WHERE[name]}'), name)
    globals()[name] = value
    return value
