"""The slam node's core configuration: its ``profile`` (``track_core.slam.profiles``) gives the defaults of
the cekf.*, pf.*, hybrid.* groups and of pose0 / pose0_var, and the experiments start from the same profile."""

import dataclasses

import numpy as np
import pytest
from rclpy.parameter import Parameter

from track_core.slam.profiles import PROFILES, VICTORIA_PARK, SlamProfile
from track_core.slam.streams import BEARING_TOLERANCE
from track_nodes.base import ParameterError
from track_nodes.base.params import all_specs
from track_nodes.slam.params import SlamNodeParams

GROUPS = {'cekf': 'slam', 'pf': 'pf', 'hybrid': 'hybrid'}  # node group -> SlamProfile field


def test_the_declared_defaults_are_the_default_profiles():
    specs = {s.name: s.default for s in all_specs(SlamNodeParams)}
    prof = PROFILES[specs['profile']]()
    assert (specs['pose0'], specs['pose0_var']) == (list(prof.pose0), list(prof.pose0_var))
    assert specs['bearing_tolerance'] == BEARING_TOLERANCE
    undeclared = set()
    for group, field in GROUPS.items():
        core = getattr(prof, field)
        for f in dataclasses.fields(core):
            name = f'{group}.{f.name}'
            if name not in specs:
                undeclared.add(name)
                continue
            v = getattr(core, f.name)
            assert specs[name] == (list(v) if isinstance(v, tuple) else v), name
    # a string field is not a group parameter (base/params.group): it keeps the core's value
    assert undeclared == {'hybrid.restore'}


@pytest.mark.parametrize('profile', sorted(PROFILES))
def test_a_node_of_each_profile_holds_that_profiles_config(ros, profile):
    from track_nodes.slam.slam import SlamNode

    node = ros.add(SlamNode(context=ros.context, parameter_overrides=[Parameter('profile', value=profile)]))
    prof = PROFILES[profile]()
    assert (node.p.cekf, node.p.pf, node.p.hybrid) == (prof.slam, prof.pf, prof.hybrid)
    assert (tuple(node.p.pose0), tuple(node.p.pose0_var)) == (prof.pose0, prof.pose0_var)


@pytest.mark.parametrize(('over', 'words'), [
    ({'cekf.sigma_v': -1.0}, ['cekf.sigma_v', '-1.0', '> 0']),
    ({'pose0_var': [0.0, 1e-6, 1e-6]}, ['pose0_var', 'positive']),
])
def test_a_bad_value_is_one_parameter_error_line(ros, over, words):
    from track_nodes.slam.slam import SlamNode

    with pytest.raises(ParameterError) as err:
        SlamNode(context=ros.context, parameter_overrides=[Parameter(k, value=v) for k, v in over.items()])
    msg = str(err.value)
    assert '\n' not in msg and all(w in msg for w in words), msg


@pytest.mark.parametrize(('kw', 'word'), [({'pose0_var': (1e-6, 0.0, 1e-6)}, 'pose0_var'),
                                          ({'pose0': (0.0, float('nan'), 0.0)}, 'pose0'),
                                          ({'hybrid': None}, 'hybrid')])
def test_the_profile_checks_name_the_field(kw, word):
    with pytest.raises(ValueError, match=f'^{word}='):
        dataclasses.replace(VICTORIA_PARK, **kw)


def test_the_prior_is_pose0_and_its_variances():
    pose0, P0 = SlamProfile(VICTORIA_PARK.slam, VICTORIA_PARK.pf, VICTORIA_PARK.hybrid, (1.0, 2.0, 0.5),
                            (0.1, 0.2, 0.3)).prior()
    np.testing.assert_array_equal(pose0, [1.0, 2.0, 0.5])
    np.testing.assert_array_equal(P0, np.diag([0.1, 0.2, 0.3]))
