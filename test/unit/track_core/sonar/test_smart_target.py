import numpy as np
import pytest

from track_core.sonar import SmartTarget, SmartTargetParams, SonarParams


def test_detection_probability_falls_with_range():
    p = SmartTargetParams()
    pd = p.detection_probability(np.array([0.0, 600.0, 2000.0]))
    assert pd[0] == pytest.approx(0.9, abs=0.01) and pd[1] == pytest.approx(0.45) and pd[2] < 1e-5


def test_naive_is_cv_model():
    rng_a, rng_b = np.random.default_rng(0), np.random.default_rng(0)
    t = SmartTarget(np.array([300.0, 12.25, 300.0, -12.25]), params=SmartTargetParams(naive=True))
    s = SonarParams()
    x = t.step(rng_a, True, np.zeros(2))
    rng_b.random()  # the ping draw
    np.testing.assert_allclose(x, s.F @ [300.0, 12.25, 300.0, -12.25] + np.linalg.cholesky(s.Q)
                               @ rng_b.standard_normal(4))


def test_evades_with_bounded_turn_and_accel_then_cruises():
    params = SmartTargetParams(p_max=1.0, r_50=1e4)
    t = SmartTarget(np.array([300.0, 12.25, 300.0, -12.25]), sonar=SonarParams(q_s=1e-9), params=params)
    rng = np.random.default_rng(0)
    xs = [t.x.copy()]
    for k in range(60):
        xs.append(t.step(rng, k < 30, np.zeros(2)))
    xs = np.array(xs)
    assert t.detections == 30 and t.first_detection_t == 0.0
    speed = np.hypot(xs[:, 1], xs[:, 3])
    head = np.arctan2(xs[:, 1], xs[:, 3])
    assert np.all(np.abs(np.diff(speed)) <= params.max_accel + 1e-3)
    assert np.all(np.abs(np.angle(np.exp(1j * np.diff(head)))) <= params.max_turn_rate + 1e-3)
    assert speed[8] > speed[0] + 4  # sped up to evade_speed (22 m/s) while evading
    assert speed[-1] == pytest.approx(speed[0], abs=0.1)  # cruising again after the quiet period
    away = np.arctan2(xs[32, 0], xs[32, 2])
    assert abs(np.angle(np.exp(1j * (head[32] - away)))) < 0.1  # heading away from the observer


def test_bad_params():
    with pytest.raises(ValueError, match=r'^p_max must be'):
        SmartTargetParams(p_max=1.5)
    with pytest.raises(ValueError, match=r'^max_turn_rate must be'):
        SmartTargetParams(max_turn_rate=-1.0)
