import pytest
from rclpy.node import Node
from rclpy.parameter import Parameter

from track_nodes.base import Param, ParameterError, declare_params

SPECS = (Param('gain', 1.0, 'a gain', 0.0, 10.0), Param('count', 3, 'a count', 1, 5),
         Param('mode', 'a', 'a mode', choices=('a', 'b')), Param('flag', True, 'a flag'))


def _node(ros, **overrides):
    return ros.add(Node('n', context=ros.context,
                        parameter_overrides=[Parameter(k, value=v) for k, v in overrides.items()]))


def test_defaults_and_overrides(ros):
    p = declare_params(_node(ros, gain=2.5), SPECS)
    assert (p.gain, p.count, p.mode, p.flag) == (2.5, 3, 'a', True)


@pytest.mark.parametrize(('override', 'words'), [
    ({'gain': 11.0}, 'gain'), ({'gain': float('nan')}, 'gain'), ({'count': 0}, 'count'),
    ({'mode': 'c'}, 'mode'), ({'gain': 'x'}, 'gain'),
])
def test_bad_values_name_parameter_value_and_range(ros, override, words):
    with pytest.raises(ParameterError) as err:
        declare_params(_node(ros, **override), SPECS)
    msg = str(err.value)
    assert words in msg and 'allowed' in msg and '\n' not in msg


def test_descriptor_carries_range(ros):
    node = _node(ros)
    declare_params(node, SPECS)
    d = node.describe_parameter('gain')
    assert d.floating_point_range[0].to_value == 10.0 and 'allowed' in d.description
