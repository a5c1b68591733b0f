"""Pairs at common instants, gated batched scores, windowed combination, one-to-one and metrics."""

from dataclasses import replace

import numpy as np
import pytest

from track_core.ais import (
    PATROL,
    RADAR,
    Metrics,
    PairTable,
    ShipTruth,
    evaluate,
    match_one_to_one,
    pair_instants,
)
from track_core.ais.association import _windowed
from track_core.ais.sources import SourceReports, simulate_source
from track_core.geofeasibility import ScoreWindow, score


def _reports(name, times, tracks, mu, sigma, mmsi) -> SourceReports:
    n = len(times)
    R = np.broadcast_to(np.eye(2) * sigma**2, (n, 2, 2)).copy()
    return SourceReports(name, [f'{name}{i}' for i in range(len(mmsi))], np.asarray(mmsi, np.int64),
                         np.asarray(times, float), np.asarray(tracks), np.asarray(mu, float), R, np.asarray(mu, float))


@pytest.fixture(scope='module')
def sources():
    from track_core.ais import default_path, read_ais

    if not default_path().is_file():
        pytest.skip('shared AIS data not found')
    tr = ShipTruth(read_ais())
    rng = np.random.default_rng(7)
    return simulate_source(tr, RADAR, rng, 0.0, 900.0), simulate_source(tr, PATROL, rng, 0.0, 900.0)


def test_pair_instants_is_every_cross_pair_at_common_times(sources):
    a, b = sources
    pi = pair_instants(a, b)
    got = set(zip(pi.ia.tolist(), pi.ib.tolist(), strict=True))
    want = {(i, j) for j in range(len(b)) for i in np.flatnonzero(np.abs(a.t - b.t[j]) < 1e-6).tolist()}
    assert got == want and len(got) == len(pi)
    assert len(pi) > 50_000


def test_pair_instants_tolerance_and_no_overlap():
    a = _reports('a', [0.0, 1.0, 2.0], [0, 0, 0], np.zeros((3, 2)), 1.0, [1])
    b = _reports('b', [1.0004, 5.0], [0, 0], np.zeros((2, 2)), 1.0, [1])
    assert len(pair_instants(a, b, tol=1e-3)) == 1
    assert len(pair_instants(a, replace(b, t=np.array([7.0, 9.0])))) == 0
    with pytest.raises(ValueError, match='tol'):
        pair_instants(a, b, tol=0.0)


def test_gate_is_exact(sources):
    """Gated pairs are exactly 0 for the methods that are 0 on disjoint ellipses; the gate changes nothing."""
    a, b = sources
    table = PairTable(a, b)
    assert 0 < table.near.size < len(table) / 10
    for method in ('exact', 'glr_thresholded'):
        g, n_geom = table.score(method)
        assert n_geom == table.near.size
        far = np.setdiff1d(np.arange(len(table)), table.near)[:20000]
        ia, ib = table.pi.ia[far], table.pi.ib[far]
        assert np.all(score(a.mu[ia], a.R[ia], b.mu[ib], b.R[ib], method) == 0.0)
        assert np.all(g[far] == 0.0)
    g_ungated, n_all = table.score('exact', gate=False)
    assert n_all == len(table)
    np.testing.assert_array_equal(g_ungated, table.score('exact')[0])
    assert table.score('glr')[1] == len(table)                        # glr is never gated


@pytest.mark.parametrize('mean', ['geometric', 'harmonic'])
@pytest.mark.parametrize('window', [1, 3, 10])
def test_windowed_equals_score_window(mean, window):
    rng = np.random.default_rng(window)
    counts = np.array([5, 1, 12, 3, 20])
    start = np.concatenate([[0], np.cumsum(counts)[:-1]])
    g = rng.uniform(0, 1, counts.sum())
    g[rng.random(g.size) < 0.15] = 0.0
    ref = []
    for s, c in zip(start, counts, strict=True):
        sw = ScoreWindow(mean, max_instants=window)
        for k in range(c):
            sw.add(float(k), float(g[s + k]))
            ref.append(sw.value())
    np.testing.assert_allclose(_windowed(g, start, counts, window, mean), ref, rtol=1e-12, atol=1e-15)


def test_decisions_majority_one_to_one_and_metrics():
    # tracks a0, a1 (ships 1, 2) and b0, b1 (ships 2, 1) at 4 common instants; a0 is near both b's
    times = np.repeat([0.0, 1.0, 2.0, 3.0], 2)
    a = _reports('a', times, np.tile([0, 1], 4), np.tile([[0.0, 0.0], [500.0, 0.0]], (4, 1)), 10.0, [1, 2])
    b = _reports('b', times, np.tile([0, 1], 4), np.tile([[500.0, 0.0], [5.0, 0.0]], (4, 1)), 10.0, [2, 1])
    table = PairTable(a, b)
    assert len(table) == 16 and table.counts.tolist() == [4, 4, 4, 4]
    g = np.zeros(16)                          # a1–b1 (ships 2, 1): never feasible
    pair = lambda x, y: (a.track[table.pi.ia] == x) & (b.track[table.pi.ib] == y)  # noqa: E731
    g[pair(0, 1)] = [0.9, 0.0, 0.8, 0.7]      # true pair with one zero instant: majority → same ship
    g[pair(1, 0)] = [0.9, 0.9, 0.9, 0.9]      # true pair
    g[pair(0, 0)] = [0.6, 0.6, 0.4, 0.6]      # wrong pair, associated 3/4 → declared by threshold only
    dec = table.decide(g, window=1)
    declared = {(int(x), int(y)) for x, y in zip(dec.a[dec.declared], dec.b[dec.declared], strict=True)}
    assert declared == {(0, 1), (1, 0), (0, 0)}
    m = evaluate(a, b, dec)
    assert (m.tp, m.fp, m.fn) == (2, 1, 0) and m.precision == pytest.approx(2 / 3) and m.recall == 1.0
    dec1 = table.decide(g, window=1, one_to_one=True)                 # a0 keeps b1 (mean 0.6 > 0.55)
    assert {(int(x), int(y)) for x, y in zip(dec1.a[dec1.declared], dec1.b[dec1.declared], strict=True)} == \
        {(0, 1), (1, 0)}
    assert evaluate(a, b, dec1).f1 == 1.0
    # the paper's geometric mean over all instants: the one zero instant vetoes the true pair a0–b1
    dec_all = table.decide(g, window=10**6)
    assert not dec_all.declared[(dec_all.a == 0) & (dec_all.b == 1)].any()


def test_one_to_one_prefers_the_heavier_matching():
    pa, pb = np.array([0, 0, 1]), np.array([0, 1, 0])
    keep = match_one_to_one(pa, pb, np.array([0.9, 0.8, 0.85]), np.array([True, True, True]))
    assert keep.tolist() == [False, True, True]                       # 0.8 + 0.85 > 0.9


def test_metrics_edge_cases():
    empty = Metrics(0, 0, 0, 0)                                       # nothing declared, nothing to find
    assert (empty.precision, empty.recall) == (1.0, 1.0)
    m = Metrics(3, 1, 2, 0)
    assert m.precision == 0.75 and m.recall == 0.6 and m.f1 == pytest.approx(2 * 0.75 * 0.6 / 1.35)
    assert set(m.as_dict()) >= {'precision', 'recall', 'f1'}


# ---- short pairs: the prior on the per-instant association rate ----

def test_short_pair_rule():
    from track_core.ais.association import declare

    n = np.array([1, 2, 3, 3, 4, 10, 10, 40, 40, 3])
    k = np.array([1, 1, 1, 0, 1, 5, 4, 20, 19, 2])
    np.testing.assert_array_equal(declare(n, k), k / n >= 0.5)                    # ν = 0: the plain majority
    got = declare(n, k, prior_weight=2.0, prior_rate=0.75)                       # (k + 1.5) / (n + 2) ≥ 1/2
    np.testing.assert_array_equal(got, [True, True, True, False, False, True, False, True, False, True])
    assert not got[3]                               # never associated: never declared, whatever the prior
    assert declare(np.array([3]), np.array([1]), 2.0, 0.75)[0] and not declare(np.array([3]), np.array([1]))[0]
    nn, kk = (g.ravel() for g in np.meshgrid(np.arange(1, 60), np.arange(0, 60)))
    kk, nn = kk[kk <= nn], nn[kk <= nn]
    for rate in (0.75, 0.8, 0.95):                   # ν = 2: k ≥ ⌊n/2⌋ and k ≥ 1, for any r̄ in [0.75, 1)
        np.testing.assert_array_equal(declare(nn, kk, 2.0, rate), (kk >= nn // 2) & (kk >= 1))
    with pytest.raises(ValueError, match='prior'):
        declare(n, k, prior_weight=-1.0)


def test_short_pair_rule_saves_the_issue_example():
    """0.86, 0, 0.18: one zero instant no longer outvotes a true pair of three instants."""
    times = np.array([0.0, 1.0, 2.0])
    a = _reports('a', times, [0, 0, 0], np.zeros((3, 2)), 10.0, [1])
    b = _reports('b', times, [0, 0, 0], np.zeros((3, 2)), 10.0, [1])
    table = PairTable(a, b)
    g = np.array([0.86, 0.0, 0.18])
    assert not table.decide(g).declared[0]
    assert table.decide(g, prior_weight=2.0).declared[0]


# ---- bounded memory: chunked pair-instants, streamed decisions ----

def test_chunks_cover_every_pair_instant_once(sources):
    from track_core.ais.association import pair_tables

    a, b = sources
    whole = pair_instants(a, b)
    for max_pairs in (1, 5000, 10**9):
        tables = list(pair_tables(a, b, max_pairs=max_pairs))
        assert sum(len(t) for t in tables) == len(whole)
        biggest_instant = int(np.max(np.unique(a.t, return_counts=True)[1])) * \
            int(np.max(np.unique(b.t, return_counts=True)[1]))
        assert max(len(t) for t in tables) <= max_pairs + biggest_instant       # an instant is never split
        last = [t.a.t.max() for t in tables]
        assert np.all(np.diff(last) > 0)                                        # time order
    assert len(tables) == 1
    with pytest.raises(ValueError, match='max_pairs'):
        list(pair_tables(a, b, max_pairs=0))


@pytest.mark.parametrize('max_pairs', [3000, 40_000])
def test_streamed_decisions_equal_one_table(sources, max_pairs):
    """Chunks change nothing for a deterministic method: windows carry across chunk borders exactly."""
    from track_core.ais.association import StreamingDecisions, pair_tables

    a, b = sources
    whole = PairTable(a, b)
    g_all, _ = whole.score('exact')
    rules = {(1, 'geometric'): [0.3, 0.5], (3, 'geometric'): [0.5], (10, 'harmonic'): [0.5],
             (None, 'geometric'): [0.5]}
    stream = StreamingDecisions(len(a.ids), len(b.ids), rules)
    chunks = 0
    for t in pair_tables(a, b, max_pairs=max_pairs):
        stream.add(t, t.score('exact')[0])
        chunks += 1
    assert chunks >= 3
    for (window, mean), ths in rules.items():
        for th in ths:
            for o2o, nu in ((False, 0.0), (True, 2.0)):
                ref = whole.decide(g_all, window=window or 10**9, mean=mean, threshold=th, one_to_one=o2o,
                                   prior_weight=nu)
                got = stream.decide(window, mean, th, one_to_one=o2o, prior_weight=nu)
                np.testing.assert_array_equal(got.a, ref.a)
                np.testing.assert_array_equal(got.b, ref.b)
                np.testing.assert_array_equal(got.instants, ref.instants)
                np.testing.assert_array_equal(got.associated, ref.associated)
                np.testing.assert_array_equal(got.declared, ref.declared)
                np.testing.assert_allclose(got.combined, ref.combined, rtol=1e-9, atol=1e-12)   # sums in another order
    with pytest.raises(ValueError, match='not accumulated'):
        stream.decide(3, 'geometric', 0.7)


def test_scoring_memory_does_not_grow_with_the_duration(synthetic):
    """Peak traced memory of scoring 1 h vs 4 h of the same traffic: the pair-instants quadruple, the peak does not."""
    import tracemalloc

    from track_core.ais.association import StreamingDecisions, pair_tables

    rng = np.random.default_rng(11)
    ships = {100 + s: [(600.0 * k, 50.0 + 0.02 * np.sin(s), -1.0 + 0.03 * np.cos(s) + 1e-5 * k) for k in range(25)]
             for s in range(40)}
    tr = ShipTruth(synthetic(ships))
    peaks, sizes = [], []
    for hours in (1, 4):
        a = simulate_source(tr, RADAR, rng, 0.0, 3600.0 * hours)
        b = simulate_source(tr, PATROL, rng, 0.0, 3600.0 * hours)
        stream = StreamingDecisions(len(a.ids), len(b.ids), {(1, 'geometric'): [0.5], (3, 'geometric'): [0.5]})
        tracemalloc.start()
        n = 0
        for t in pair_tables(a, b, max_pairs=20_000):
            stream.add(t, t.score('glr')[0])                               # glr: every pair-instant computed
            n += len(t)
        peaks.append(tracemalloc.get_traced_memory()[1])
        tracemalloc.stop()
        sizes.append(n)
    assert sizes[1] > 3.5 * sizes[0] > 3.5 * 100_000
    assert peaks[1] < 1.3 * peaks[0]
