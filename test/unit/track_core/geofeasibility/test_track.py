import numpy as np
import pytest

from track_core.geofeasibility import PairWindows, ScoreWindow, combine_scores, common_instants, score, track_score


def test_means():
    assert combine_scores([0.5, 1.0], 'harmonic') == pytest.approx(2 / 3)
    assert combine_scores([0.25, 1.0], 'geometric') == pytest.approx(0.5)
    assert combine_scores([0.7]) == pytest.approx(0.7)
    assert combine_scores([0.9, 0.0, 1.0], 'harmonic') == 0.0
    assert combine_scores([0.9, 0.0, 1.0], 'geometric') == 0.0
    for bad in ([], [np.nan], [1.5]):
        with pytest.raises(ValueError):
            combine_scores(bad)
    with pytest.raises(ValueError, match='unknown mean'):
        combine_scores([0.5], 'arithmetic')


def test_common_instants_match_within_tolerance_once_each():
    i1, i2 = common_instants([0.0, 1.0, 2.0, 3.0], [3.0000001, 0.5, 1.0, 2.2], tol=1e-3)
    assert i1.tolist() == [1, 3] and i2.tolist() == [2, 0]
    assert common_instants([], [1.0])[0].size == 0


def test_track_score_over_a_window():
    t = np.arange(10.0)
    mu1 = np.zeros((10, 2))
    mu2 = np.zeros((10, 2))
    mu2[:5, 0] = 50.0          # disjoint in the first half
    R = np.tile(np.eye(2), (10, 1, 1))
    assert track_score(t, mu1, R, t, mu2, R) == 0.0
    assert track_score(t, mu1, R, t, mu2, R, window=4.0) == 1.0       # instants 5..9
    assert track_score(t, mu1, R, t, mu2, R, max_instants=5) == 1.0
    mu2[5:, 0] = 1.0
    g = score(mu1[5:], R[5:], mu2[5:], R[5:], 'glr')
    assert track_score(t, mu1, R, t, mu2, R, method='glr', mean='geometric', window=4.5) == pytest.approx(g[0])
    with pytest.raises(ValueError, match='no common instant'):
        track_score(t, mu1, R, t + 0.5, mu2, R)


def test_score_window_streaming():
    w = ScoreWindow('harmonic', window=2.0, max_instants=10)
    for t, g in ((0.0, 0.0), (1.0, 0.5), (2.0, 1.0)):
        w.add(t, g)
    assert w.value() == 0.0 and len(w) == 3
    w.add(2.5, 1.0)               # drops t = 0
    assert len(w) == 3 and w.value() == pytest.approx(3 / 4)
    with pytest.raises(ValueError, match='backwards'):
        w.add(1.0, 0.5)
    with pytest.raises(ValueError):
        ScoreWindow(window=0.0)


@pytest.mark.parametrize('mean', ['harmonic', 'geometric'])
@pytest.mark.parametrize('k', [1, 3, 10, 12])
def test_pair_windows_equal_one_score_window_per_pair(mean, k):
    """PairWindows (count + trailing positive run) gives ScoreWindow's combination bit for bit."""
    rng = np.random.default_rng(k)
    n_pairs = 60
    ref = {p: ScoreWindow(mean, max_instants=k) for p in range(n_pairs)}
    win = PairWindows(mean, max_instants=k)
    for step in range(40):
        keys = np.flatnonzero(rng.random(n_pairs) < 0.7)               # some pairs absent at some instants
        g = np.where(rng.random(keys.size) < 0.15, 0.0, rng.uniform(1e-3, 1.0, keys.size))
        g[rng.random(keys.size) < 0.05] = 1.0
        combined, instants = win.add(keys * 7 + 3, g, float(step))
        for p, v, c, m in zip(keys, g, combined, instants, strict=True):
            ref[p].add(float(step), float(v))
            assert (c, m) == (ref[p].value(), len(ref[p]))
    assert len(win) == n_pairs
    np.testing.assert_array_equal(win.instants(np.arange(n_pairs) * 7 + 3), [len(ref[p]) for p in range(n_pairs)])


def test_pair_windows_refuse_what_score_window_refuses():
    win = PairWindows('geometric', 3)
    win.add([1, 2], [0.5, 0.0], 1.0)
    with pytest.raises(ValueError, match='backwards'):
        win.add([1], [0.5], 0.5)
    with pytest.raises(ValueError, match=r'\[0, 1\]'):
        win.add([1], [1.5], 2.0)
    with pytest.raises(ValueError, match='max_instants'):
        PairWindows('geometric', 0)
