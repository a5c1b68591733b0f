import math

import numpy as np
import pytest

from track_core.geofeasibility import (
    FLOOR_2SIGMA,
    PairWindows,
    ScoreWindow,
    combine_scores,
    common_instants,
    score,
    track_score,
    with_prior,
)
from track_core.geofeasibility.track import check_prior


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
    """PairWindows given only some pairs (the others scored 0) gives ScoreWindow's combination bit for bit."""
    rng = np.random.default_rng(k)
    n_pairs = 60
    ref = {p: ScoreWindow(mean, max_instants=k) for p in range(n_pairs)}
    total = np.zeros(n_pairs, np.int64)
    win = PairWindows(mean, max_instants=k)
    passed = 0
    for step in range(40):
        in_call = np.flatnonzero(rng.random(n_pairs) < 0.7)            # some pairs not scored at some instants
        g = np.where(rng.random(in_call.size) < 0.15, 0.0, rng.uniform(1e-3, 1.0, in_call.size))
        g[rng.random(in_call.size) < 0.05] = 1.0
        total[in_call] += 1
        for p, v in zip(in_call, g, strict=True):
            ref[p].add(float(step), float(v))
        sent = (g > 0) | (rng.random(in_call.size) < 0.5)              # a gate leaves out some zero scores
        keys = in_call[sent]
        combined, instants = win.add(keys * 7 + 3, g[sent], float(step), total[keys])
        passed += keys.size
        for p, c, m in zip(keys, combined, instants, strict=True):
            assert (c, m) == (ref[p].value(), len(ref[p]))
    assert passed > 0.8 * 0.7 * 0.5 * 40 * n_pairs
    assert len(win) <= n_pairs and np.all(win.run_len >= 1)     # only positive runs are stored


@pytest.mark.parametrize('mean', ['harmonic', 'geometric'])
@pytest.mark.parametrize('k', [1, 3, 10])
def test_pair_windows_with_a_floor_equal_one_score_window_per_pair(mean, k):
    """With a floor, PairWindows fills the instants a pair was not passed with zeros, as ScoreWindow sees them."""
    rng = np.random.default_rng(100 + k)
    n_pairs, floor = 40, FLOOR_2SIGMA
    ref = {p: ScoreWindow(mean, max_instants=k, floor=floor) for p in range(n_pairs)}
    total = np.zeros(n_pairs, np.int64)
    win = PairWindows(mean, max_instants=k, floor=floor)
    floored = 0
    for step in range(40):
        in_call = np.flatnonzero(rng.random(n_pairs) < 0.7)
        g = np.where(rng.random(in_call.size) < 0.3, 0.0, rng.uniform(1e-3, 1.0, in_call.size))
        total[in_call] += 1
        for p, v in zip(in_call, g, strict=True):
            ref[p].add(float(step), float(v))
        sent = (g > 0) | (rng.random(in_call.size) < 0.5)
        keys = in_call[sent]
        combined, instants = win.add(keys * 7 + 3, g[sent], float(step), total[keys])
        for p, c, m in zip(keys, combined, instants, strict=True):
            assert (c, m) == (ref[p].value(), len(ref[p]))
            floored += bool(c > 0 and any(v == 0 for _, v in ref[p]._buf))
            # a window with no positive score is not stored
            assert (p * 7 + 3 in win.keys) == any(v > 0 for _, v in ref[p]._buf)
    assert floored > 20 or k == 1                         # windows holding a zero and still positive


def test_a_floor_is_evidence_not_a_veto_and_changes_nothing_above_it():
    e = FLOOR_2SIGMA
    assert math.isclose(combine_scores([1.0, 0.0, 1.0], 'geometric', e), e ** (1 / 3))
    assert math.isclose(combine_scores([1.0, 0.0], 'harmonic', e), 2 / (1 + 1 / e))
    assert combine_scores([0.0, 0.0], 'geometric', e) == 0.0           # nothing speaks for the pair
    assert combine_scores([0.3, 0.9], 'geometric', e) == combine_scores([0.3, 0.9], 'geometric')
    assert combine_scores([1.0, 0.0, 1.0], 'geometric') == 0.0          # floor 0: the paper's means
    for bad in (-0.1, 1.0, float('nan')):
        with pytest.raises(ValueError, match='floor'):
            combine_scores([0.5], 'geometric', bad)
        with pytest.raises(ValueError, match='floor'):
            PairWindows('geometric', 3, bad)


@pytest.mark.parametrize('mean', ['geometric', 'harmonic'])
def test_a_prior_is_its_instants_in_the_mean_and_fades_as_the_window_fills(mean):
    """ν instants scoring s̄ join the mean: equal to combining the window's scores with them (integer ν);
    0 stays 0; ν = 0 changes nothing; a full window moves less than a young one."""
    rng = np.random.default_rng(3)
    for n in (1, 2, 5, 15):
        g = rng.uniform(0.05, 1.0, n)
        c = combine_scores(g, mean)
        for nu, sbar in ((1, 0.8), (2, 0.8), (3, 1.0)):
            assert math.isclose(float(with_prior(c, n, mean, nu, sbar)), combine_scores([*g, *[sbar] * nu], mean),
                                rel_tol=1e-12)
    c = np.array([0.2, 0.0, 0.2])
    out = with_prior(c, np.array([1, 1, 15]), mean, 2.0, 0.8)
    assert out[1] == 0.0                                        # nothing speaks for the pair: still 0
    assert out[0] > out[2] > 0.2                                # the young window leans more
    assert np.array_equal(with_prior(c, np.array([1, 1, 15]), mean, 0.0, 0.8), c)
    for bad in ((-1.0, 0.8), (2.0, 0.0), (2.0, 1.5), (float('nan'), 0.8), ('2', 0.8)):
        with pytest.raises(ValueError, match='prior'):
            check_prior(*bad)


def test_pair_windows_refuse_what_score_window_refuses():
    win = PairWindows('geometric', 3)
    win.add([1, 2], [0.5, 0.0], 1.0, [1, 1])
    with pytest.raises(ValueError, match='backwards'):
        win.add([1], [0.5], 0.5, [2])
    with pytest.raises(ValueError, match=r'\[0, 1\]'):
        win.add([1], [1.5], 2.0, [2])
    with pytest.raises(ValueError, match='total'):
        win.add([1], [0.5], 2.0, [0])
    with pytest.raises(ValueError, match='max_instants'):
        PairWindows('geometric', 0)
