from dataclasses import dataclass

import pytest
from rclpy.node import Node
from rclpy.parameter import Parameter

from track_nodes.base import ParameterError, group, param
from track_nodes.base.params import Param, declare, declare_params, param_specs

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


@dataclass
class Core:
    """A core configuration dataclass with its own check."""

    gain: float = 2.0
    steps: tuple = (1.0, 2.0)

    def __post_init__(self):
        if self.gain < 0:
            raise ValueError('gain must be >= 0')


@dataclass
class Demo:
    mode: str = param('a', 'a mode', choices=('a', 'b'))
    rate: float = param(1.0, 'a rate', 0.0, 10.0, live=True)
    xs: list[float] = param([1.0, 2.0], 'a vector')
    scale: float = param(0.0, 'follows the mode', 0.0, 100.0, default_from=lambda v: 10.0 if v['mode'] == 'b' else 1.0)
    core: Core = group(Core, default_from=lambda v: Core(gain=5.0) if v['mode'] == 'b' else Core())

    @staticmethod
    def error_context(values):
        return f"mode {values['mode']}" if 'mode' in values else None


def test_a_parameter_dataclass_is_declared_in_field_order_with_typed_values(ros):
    node = _node(ros, rate=2.0, **{'core.gain': 3.0})
    p = declare(node, Demo)
    assert isinstance(p, Demo) and (p.mode, p.rate, p.xs, p.scale) == ('a', 2.0, [1.0, 2.0], 1.0)
    assert p.core == Core(gain=3.0) and node.get_parameter('core.steps').value == [1.0, 2.0]
    d = node.describe_parameter('rate')
    assert not d.read_only and d.floating_point_range[0].to_value == 10.0 and 'a rate' in d.description
    assert node.describe_parameter('mode').read_only
    assert [s.name for s in param_specs(Demo)] == ['mode', 'rate', 'xs', 'scale']


def test_defaults_from_earlier_fields_and_a_list_default_is_not_shared(ros):
    p = declare(_node(ros, mode='b'), Demo)
    assert p.scale == 10.0 and p.core == Core(gain=5.0)
    q = declare(_node(ros), Demo)
    q.xs.append(3.0)
    assert Demo().xs == [1.0, 2.0]


@pytest.mark.parametrize(('override', 'words'), [
    ({'rate': 11.0}, 'mode a: parameter rate'), ({'core.gain': -1.0}, 'core.gain'), ({'mode': 'c'}, 'mode'),
])
def test_a_bad_value_is_one_parameter_error_line_with_its_context(ros, override, words):
    with pytest.raises(ParameterError) as err:
        declare(_node(ros, **override), Demo)
    assert words in str(err.value) and '\n' not in str(err.value)


def test_a_field_not_declared_with_param_is_a_programming_error(ros):
    @dataclass
    class Bad:
        x: float = 1.0

    with pytest.raises(TypeError, match='param'):
        declare(_node(ros), Bad)


@dataclass
class Kinds:
    """One parameter of each kind a node declares."""

    name: str = param('track', 'a string')
    topics: list[str] = param([''], 'a list of strings')
    flag: bool = param(True, 'a flag')
    count: int = param(3, 'a count', 1, 5)
    gain: float = param(1.0, 'a gain', 0.0, 10.0, live=True)
    free: float = param(0.5, 'an unbounded number')
    xs: list[float] = param([1.0, 2.0], 'a vector')


def test_ros2_param_describe_gives_a_range_only_to_numbers(ros):
    """What ``ros2 param describe`` shows, read through the node's DescribeParameters service: strings,
    string lists and flags have no numeric range and no "[-inf, inf]" in their description."""
    from rclpy.parameter_client import AsyncParameterClient

    from track_nodes.base import TrackNode

    class KindsNode(TrackNode):
        DEFAULT_NAME = 'kinds'
        Params = Kinds

    ros.add(KindsNode(context=ros.context))
    client = AsyncParameterClient(ros.add(Node('describer', context=ros.context)), 'kinds')
    assert ros.spin_until(client.services_are_ready, timeout=60)
    names = ['name', 'topics', 'flag', 'count', 'gain', 'free', 'xs']
    future = client.describe_parameters(names)
    assert ros.spin_until(future.done, timeout=60)
    d = dict(zip(names, future.result().descriptors, strict=True))
    for key in ('name', 'topics', 'flag', 'xs'):
        assert not d[key].floating_point_range and not d[key].integer_range, key
        assert 'inf' not in d[key].description and '[' not in d[key].description, (key, d[key].description)
    assert 'allowed: any string; read-only after start' in d['name'].description
    assert 'allowed: a list of strings' in d['topics'].description
    assert 'allowed: true or false' in d['flag'].description
    assert 'allowed: a list of numbers;' in d['xs'].description
    assert (d['count'].integer_range[0].from_value, d['count'].integer_range[0].to_value) == (1, 5)
    assert d['gain'].floating_point_range[0].to_value == 10.0 and not d['gain'].read_only
    assert 'allowed: [-inf, inf]' in d['free'].description  # a number: its (open) range is the truth
