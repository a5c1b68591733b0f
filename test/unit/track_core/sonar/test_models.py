import math

import numpy as np
import pytest

from track_core.sonar import SensorMode, SonarParams, bearing, measure, residual, simulate_measurement


def test_bearing_from_north_all_quadrants():
    o = np.zeros(2)
    for xy, b in [((0, 1), 0.0), ((1, 0), math.pi / 2), ((0, -1), math.pi), ((-1, 0), -math.pi / 2)]:
        assert bearing(np.array(xy, float), o) == pytest.approx(b)
    z = measure(np.array([[3.0, 0, 4.0, 0]]), np.zeros(2), 'active')
    np.testing.assert_allclose(z, [[math.atan2(3, 4), 5.0]])
    assert measure(np.array([3.0, 0, 4.0, 0]), np.zeros(2), SensorMode.PASSIVE).shape == (1,)


def test_residual_wraps_bearing_only():
    d = residual(np.array([math.pi - 0.01, 100.0]), np.array([-math.pi + 0.01, 90.0]))
    np.testing.assert_allclose(d, [-0.02, 10.0], atol=1e-12)


def test_simulated_noise_matches_table1():
    p = SonarParams()
    rng = np.random.default_rng(0)
    x = np.array([300.0, 0, 300.0, 0])
    z = np.array([simulate_measurement(rng, x, np.zeros(2), 'active', p) for _ in range(4000)])
    assert np.std(z[:, 0]) == pytest.approx(math.radians(1.0), rel=0.05)
    assert np.std(z[:, 1]) == pytest.approx(5.0, rel=0.05)


@pytest.mark.parametrize(('kw', 'name'), [({'n_particles': 0}, 'n_particles'), ({'T': -1.0}, 'T'),
                                          ({'sigma_b': 0.0}, 'sigma_b'), ({'q_s': float('nan')}, 'q_s')])
def test_bad_params_one_line(kw, name):
    with pytest.raises(ValueError, match=f'^{name} must be') as exc:
        SonarParams(**kw)
    assert '\n' not in str(exc.value)


def test_mode_parse():
    assert SensorMode.parse(True) is SensorMode.ACTIVE
    assert SensorMode.parse('PASSIVE') is SensorMode.PASSIVE
    with pytest.raises(ValueError, match='sensor mode'):
        SensorMode.parse('sonar')
