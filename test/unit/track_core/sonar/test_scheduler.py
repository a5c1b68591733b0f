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
    ({'initial_pings': 0}, '^initial_pings must be'),
    ({'initial_pings': 1.5}, '^initial_pings must be'),
])
def test_bad_parameters_raise_one_line(kw, words):
    with pytest.raises(ValueError, match=words) as exc:
        CovarianceScheduler(**kw)
    assert '\n' not in str(exc.value)


def test_diagonal_vector_and_fixed():
    assert np.array_equal(CovarianceScheduler(P_D=[1, 2, 3, 4]).P_D, np.diag([1.0, 2, 3, 4]))
    f = FixedScheduler('passive')
    assert f.decide(np.eye(4) * 1e6) is SensorMode.PASSIVE


def test_initial_pings_are_active_whatever_the_covariance_then_eq7():
    quiet = DEFAULT_P_D + np.diag([1.0, 0, 0, 0])  # ‖P_D − Cov‖₂ = 1 < δ: eq. 7 says passive
    s = CovarianceScheduler(delta=5.0, initial_pings=3)
    assert s.next_mode is SensorMode.ACTIVE  # step 1
    assert [s.decide(quiet) for _ in range(4)] == [SensorMode.ACTIVE, SensorMode.ACTIVE,
                                                   SensorMode.PASSIVE, SensorMode.PASSIVE]
    s.reset()  # a new run starts the count again
    assert [s.decide(quiet) for _ in range(3)] == [SensorMode.ACTIVE, SensorMode.ACTIVE, SensorMode.PASSIVE]
    # the default is Algorithm 3's: one active step, then eq. 7
    assert CovarianceScheduler(delta=5.0).decide(quiet) is SensorMode.PASSIVE
    # a scheduler that starts passive is eq. 7 from the first decision
    assert CovarianceScheduler(delta=5.0, first='passive', initial_pings=3).decide(quiet) is SensorMode.PASSIVE


def test_initial_pings_in_the_tracker_adds_active_steps_only_at_the_start():
    from track_core.sonar import SonarParams
    from track_core.sonar.models import simulate_measurement
    from track_core.sonar.sspf import make_tracker

    def modes(initial_pings):
        p = SonarParams()
        rng = np.random.default_rng(5)
        tr = make_tracker('ss-pf', p, np.random.default_rng(6), delta=50.0, initial_pings=initial_pings)
        x, obs = np.array([300.0, 0.0, 300.0, -5.0]), np.zeros(2)
        tr.initialize(x, np.diag([400.0, 4.0, 400.0, 4.0]))
        out = []
        for _ in range(8):
            x = p.F @ x
            mode = tr.next_mode
            tr.step(simulate_measurement(rng, x, obs, mode, p), mode, obs)
            out.append(mode)
        return out

    one, two = modes(1), modes(2)
    assert one[:2] == [SensorMode.ACTIVE, SensorMode.PASSIVE]  # eq. 7 at δ = 50 goes passive after one fix
    assert two[:2] == [SensorMode.ACTIVE, SensorMode.ACTIVE]
    assert SensorMode.PASSIVE in two[2:]  # and eq. 7 decides afterwards: not active at every step
