import numpy as np
import pytest

from track_core.sonar import DEFAULT_P_D, CovarianceScheduler, FixedScheduler, SensorMode


def test_eq7_spectral_norm_rule_and_first_active():
    s = CovarianceScheduler(delta=5.0)
    assert s.next_mode is SensorMode.ACTIVE
    assert s.decide(DEFAULT_P_D + np.diag([4.9, 0, 0, 0])) is SensorMode.PASSIVE
    assert s.decide(DEFAULT_P_D + np.diag([0, 0, 5.1, 0])) is SensorMode.ACTIVE
    assert s.next_mode is SensorMode.ACTIVE
    # two-sided: a covariance much *smaller* than P_D also exceeds δ = 1
    assert CovarianceScheduler(delta=1.0).decide(np.zeros((4, 4))) is SensorMode.ACTIVE
    assert CovarianceScheduler(delta=1.0, metric='excess').decide(np.zeros((4, 4))) is SensorMode.PASSIVE
    s.reset()
    assert s.next_mode is SensorMode.ACTIVE


def test_spectral_norm_is_largest_singular_value():
    s = CovarianceScheduler(P_D=np.zeros((4, 4)), delta=0.0)
    A = np.array([[2.0, 1, 0, 0], [1, 2, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])
    assert s.distance(A) == pytest.approx(3.0)


@pytest.mark.parametrize(('kw', 'words'), [
    ({'delta': -1.0}, '^delta must be'),
    ({'delta': float('nan')}, '^delta must be'),
    ({'P_D': np.diag([5.0, -0.25, 5.0, 0.25])}, '^P_D: covariance is not positive semi-definite'),
    ({'P_D': np.ones((3, 3))}, '^P_D must be'),
    ({'metric': 'frobenius'}, '^metric must be'),
])
def test_bad_parameters_raise_one_line(kw, words):
    with pytest.raises(ValueError, match=words) as exc:
        CovarianceScheduler(**kw)
    assert '\n' not in str(exc.value)


def test_diagonal_vector_and_fixed():
    assert np.array_equal(CovarianceScheduler(P_D=[1, 2, 3, 4]).P_D, np.diag([1.0, 2, 3, 4]))
    f = FixedScheduler('passive')
    assert f.decide(np.eye(4) * 1e6) is SensorMode.PASSIVE
