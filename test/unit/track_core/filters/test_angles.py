import numpy as np
import pytest

from track_core.filters import circular_mean, wrap_angle


def test_wrap_half_open_interval():
    a = np.array([np.pi, -np.pi, 3 * np.pi, 0.0, 2 * np.pi + 0.1, -0.1])
    w = wrap_angle(a)
    assert np.all(w > -np.pi) and np.all(w <= np.pi)
    np.testing.assert_allclose(w, [np.pi, np.pi, np.pi, 0.0, 0.1, -0.1], atol=1e-12)


def test_circular_mean_across_pi():
    a = np.array([np.pi - 0.1, -np.pi + 0.1])
    assert abs(circular_mean(a)) == pytest.approx(np.pi)
    assert circular_mean(np.array([0.1, 0.3]), np.array([1.0, 3.0])) == pytest.approx(0.25, abs=2e-3)
