"""What every node and tool of track_nodes shares: the node base, parameters, step clock, CLI parsing."""

from track_nodes.base.names import remember_args, shared_names_problem
from track_nodes.base.node import TrackNode
from track_nodes.base.params import NoParams, ParameterError, group, param, vector
from track_nodes.base.run import EXIT_BAD_INPUT, run_node
from track_nodes.base.steps import FixedRateSteps

__all__ = ['EXIT_BAD_INPUT', 'FixedRateSteps', 'NoParams', 'ParameterError', 'TrackNode', 'group', 'param',
           'remember_args', 'run_node', 'shared_names_problem', 'vector']
