import math

import numpy as np
import pytest

from track_core.sonar import ObserverTrajectory, Scenario


def test_observer_speed_and_two_manoeuvres():
    obs = ObserverTrajectory()
    t = np.linspace(0, 40, 401)
    s = np.array([obs.state(ti) for ti in t])
    np.testing.assert_allclose(np.hypot(s[:, 1], s[:, 3]), 10.0, atol=1e-9)
    heading = np.degrees(np.arctan2(s[:, 1], s[:, 3]))
    assert heading[0] == pytest.approx(90.0) and heading[200] == pytest.approx(180.0)
    assert heading[-1] == pytest.approx(90.0)
    turning = np.abs(np.diff(heading)) > 1e-6
    assert np.count_nonzero(np.diff(turning.astype(int)) == 1) == 2  # two manoeuvres
    # position is the integral of velocity
    dt = t[1] - t[0]
    np.testing.assert_allclose(s[-1, [0, 2]], np.array(obs.start) + np.trapezoid(s[:, [1, 3]], dx=dt, axis=0),
                               atol=0.05)


def test_truth_and_prior():
    sc = Scenario()
    rng = np.random.default_rng(0)
    x = sc.simulate_truth(rng)
    assert x.shape == (41, 4)
    np.testing.assert_allclose(x[0], [300, 12.25, 300, -12.25])
    assert sc.prior_cov[0, 0] == pytest.approx(400.0) and sc.prior_cov[1, 1] == pytest.approx(4.0)
    with pytest.raises(ValueError, match='speed'):
        ObserverTrajectory(speed=-1.0)
    assert math.isfinite(sc.observer_positions()[-1, 0])


def test_jacobian_matches_finite_differences_and_pcrlb_floor():
    from track_core.sonar import measure
    from track_core.sonar.scenario import measurement_jacobian, pcrlb

    x, o = np.array([320.0, 11.0, 280.0, -12.0]), np.array([15.0, -4.0])
    for mode in ('passive', 'active'):
        J = measurement_jacobian(x, o, mode)
        num = np.stack([(measure(x + e, o, mode) - measure(x - e, o, mode)) / 2e-4 for e in 1e-4 * np.eye(4)], -1)
        np.testing.assert_allclose(J, num, atol=1e-8)
    sc = Scenario()
    truths = np.array([sc.simulate_truth(np.random.default_rng(s)) for s in range(10)])
    active, passive = pcrlb(sc, truths), pcrlb(sc, truths, np.zeros(sc.n_steps, bool))
    lam = np.linalg.eigvalsh(active[:, [0, 2]][:, :, [0, 2]])[:, -1]
    # always active is the best schedule, yet its position bound never gets below 10 m²: with
    # P_D = diag(5, .25, 5, .25), ‖P_D − Cov‖₂ > 5 for any consistent Cov (scheduler docstring)
    assert lam.min() > 15.0
    assert np.all(np.linalg.eigvalsh(passive - active)[:, 0] > -1e-9)
    assert np.trace(passive[-1]) > 2 * np.trace(active[-1])
