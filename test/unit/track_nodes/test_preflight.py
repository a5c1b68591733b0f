"""A ``--params`` layer must give each parameter the type the layer below gives it, as rcl types it
(``launch.preflight``): rcl merges two types into one entry and keeps one of them, silently."""

from __future__ import annotations

import pytest

from track_nodes.launch.preflight import params_problem
from track_nodes.launch.scenario import load_scenario


@pytest.fixture(scope='module')
def demo(repo):
    return load_scenario(str(repo / 'config/demo.yaml'))  # period: 0.1, seed: 7, x0: [0.0, ...], track_id: text


@pytest.mark.parametrize(('text', 'refused'), [
    ('period: 0.2', None), ('period: 1e-1', None),  # rcl reads a plain 1e-1 as a double (YAML 1.1: a string)
    ('period: "abc"', 'string'), ('period: "0.2"', 'string'), ('period: 1', 'integer'),
    ('seed: 7.0', 'double'), ('track_id: 5', 'integer'), ("track_id: '5'", None),
    ('x0: [1.0, 2.0, 3.0, 4.0]', None), ('x0: [1, 2, 3, 4]', 'integer array'),
])
def test_a_layer_keeps_the_type_of_the_layer_below(tmp_path, demo, text, refused):
    layer = tmp_path / 'layer.yaml'
    layer.write_text(f'/**/demo_target:\n  ros__parameters:\n    {text}\n')
    problem = params_problem([layer], demo)
    if refused is None:
        assert problem is None, problem
    else:
        assert problem is not None and f'({refused}) over' in problem and 'demo.yaml' in problem, problem


def test_each_layer_is_checked_against_the_nearest_below(tmp_path, demo):
    (tmp_path / 'a.yaml').write_text('/**/demo_target:\n  ros__parameters:\n    track_id: "x"\n')
    (tmp_path / 'b.yaml').write_text('/**/demo_target:\n  ros__parameters:\n    track_id: 3\n')
    problem = params_problem([tmp_path / 'a.yaml', tmp_path / 'b.yaml'], demo)
    assert problem is not None and problem.startswith(f'--params {tmp_path / "b.yaml"}') and 'of a.yaml' in problem
