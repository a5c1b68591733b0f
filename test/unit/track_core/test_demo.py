import numpy as np
import pytest

from track_core.demo import CVKalmanTracker, CVTarget


def test_target_is_reproducible_from_the_seed():
    a, b = CVTarget(np.array([0.0, 1.0, 0.0, 1.0])), CVTarget(np.array([0.0, 1.0, 0.0, 1.0]))
    ra, rb = np.random.default_rng(5), np.random.default_rng(5)
    for _ in range(10):
        assert np.array_equal(a.step(ra), b.step(rb))
        assert np.array_equal(a.report(ra), b.report(rb))
    assert a.t == pytest.approx(10 * a.T)


def test_target_without_process_noise_moves_straight():
    tgt = CVTarget(np.array([0.0, 2.0, 10.0, -1.0]), T=0.5, q_s=0.0)
    rng = np.random.default_rng(0)
    for _ in range(4):
        tgt.step(rng)
    assert tgt.x == pytest.approx([4.0, 2.0, 8.0, -1.0])


@pytest.mark.parametrize('bad', [dict(x0=[0, 0, 0]), dict(x0=[0, 0, 0, np.nan]), dict(T=0.0),
                                 dict(R=np.array([[1.0, 2.0], [2.0, 1.0]]))])
def test_target_rejects_bad_parameters(bad):
    kw = dict(x0=[0.0, 0.0, 0.0, 0.0]) | bad
    with pytest.raises(ValueError):
        CVTarget(np.asarray(kw.pop('x0'), dtype=float), **kw)


def test_tracker_rejects_bad_reports_and_keeps_state():
    trk = CVKalmanTracker()
    trk.update(1.0, np.array([1.0, 2.0]), np.eye(2))
    x_before = trk.x.copy()
    with pytest.raises(ValueError, match='finite'):
        trk.update(2.0, np.array([np.nan, 0.0]), np.eye(2))
    with pytest.raises(ValueError, match='backwards'):
        trk.update(0.5, np.array([1.0, 2.0]), np.eye(2))
    with pytest.raises(ValueError, match='positive'):
        trk.update(2.0, np.array([1.0, 2.0]), -np.eye(2))
    assert np.array_equal(trk.x, x_before) and trk.t == 1.0
