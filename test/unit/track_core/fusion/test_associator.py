"""PairAssociator: the fusion node's pairing, masking, windows, thresholds and CI fusion, without ROS.

``data/associator_cases.json`` holds 300 random sequences of track reports (and, for the timer
schedule, scoring ticks) with what the pre-issue-12 fusion node (``FusionNode._store``/``_score``
at commit 3ac9344) published for them: every pair's raw and combined score, window length and
verdict, and every fused estimate. The core must reproduce them: every discrete value (pairs,
window lengths, verdicts, ids) exactly, every float to 1e-6 relative. (Exact float equality held on
the machine that made the file, an AVX-512 one; numpy's SIMD loops sum in another order on AVX2,
and there 76 of the 300 cases differed in the floats only: by ~1e-16 relative, and by up to 1.1e-7
in the Monte-Carlo scores, which carry such differences through their sampling.)
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from track_core.fusion import PairAssociator, TrackReport
from track_core.fusion.associator import release_ratio_of
from track_core.geofeasibility import FLOOR_2SIGMA

DATA = json.loads((Path(__file__).parent / 'data/associator_cases.json').read_text())


def _report(ev: list) -> TrackReport:
    _, _, _, t, mu, (xx, xy, yy), *vel = ev
    R = np.array([[xx, xy], [xy, yy]], dtype=float)
    if not vel:
        return TrackReport(t, np.array(mu, dtype=float), R)
    v, (vxx, vxy, vyy) = vel
    return TrackReport(t, np.array(mu, dtype=float), R, np.array(v, dtype=float),
                       np.array([[vxx, vxy], [vxy, vyy]], dtype=float))


def _associator(p: dict) -> PairAssociator:
    return PairAssociator(p['method'], p['threshold'], p['combine'], p['window'], n_samples=p['n_samples'],
                          same_source_pairs=p['same_source_pairs'], stale_after=p['stale_after'],
                          max_prediction=p['max_prediction'], q_s=p['q_s'], seed=p['seed'],
                          stamp_rate=p['rate'] if p['schedule'] == 'stamps' else None)


def _run(p: dict, events: list) -> list:
    core = _associator(p)
    instants = []
    for ev in events:
        if ev[0] == 's':
            instant = core.score(ev[1])
            instants += [] if instant is None else [instant]
        else:
            instants += core.push(ev[1], ev[2], _report(ev))
    out = []
    for inst in instants:
        assert inst.error is None, inst.error
        pairs = [[q.a, q.b, q.score, q.combined, q.instants, q.associated] for q in inst.all_pairs()]
        fused = [[f'{f.a}+{f.b}', float(f.mu[0]), float(f.mu[1]), float(f.P[0, 0]), float(f.P[0, 1]),
                  float(f.P[1, 1])] for f in inst.fused]
        out.append([inst.t, pairs, fused])
    return out


def test_the_saved_cases_cover_every_method_and_both_schedules():
    params = [dict(zip(DATA['params'], c[0], strict=True)) for c in DATA['cases']]
    assert len(params) >= 300
    assert {p['method'] for p in params} == {'exact', 'glr', 'glr_thresholded', 'mc'}
    assert {p['schedule'] for p in params} == {'timer', 'stamps'}
    verdicts = [q[5] for c in DATA['cases'] for inst in c[2] for q in inst[1]]
    assert 0.2 < np.mean(verdicts) < 0.8  # both verdicts occur often


def _same(got, want) -> bool:
    """Discrete values equal, floats to 1e-6 relative, recursively (lists of instants, pairs, fused)."""
    if isinstance(want, float) or isinstance(got, float):
        return not isinstance(got, bool) and math.isclose(got, want, rel_tol=1e-6, abs_tol=1e-9)
    if isinstance(want, list):
        return isinstance(got, list) and len(got) == len(want) and all(map(_same, got, want))
    return got == want


@pytest.mark.parametrize('k', range(len(DATA['cases'])))
def test_identical_to_the_old_node_path(k):
    values, events, expected = DATA['cases'][k]
    p = dict(zip(DATA['params'], values, strict=True))
    got = _run(p, events)
    assert _same(got, expected), next((g, w) for g, w in zip(got, expected, strict=False) if not _same(g, w))


def test_same_source_pairs_are_masked_unless_asked_for():
    R = np.eye(2) * 4.0
    for same, want in ((False, [('/a/0', '/b/0'), ('/a/1', '/b/0')]),
                       (True, [('/a/0', '/a/1'), ('/a/0', '/b/0'), ('/a/1', '/b/0')])):
        core = PairAssociator(same_source_pairs=same)
        for source, tid in (('/a', '/a/0'), ('/a', '/a/1'), ('/b', '/b/0')):
            core.update(source, tid, TrackReport(0.0, np.zeros(2), R))
        assert [(q.a, q.b) for q in core.score(0.0).all_pairs()] == want


def test_window_combination_threshold_and_fusion():
    """Geometric mean over the last 2 instants; one far-apart instant drops the verdict; CI of the pair."""
    core = PairAssociator('exact', threshold=0.5, combine='geometric', window=2)
    R = np.eye(2) * 4.0

    def at(t, xb):
        core.update('/a', 'a', TrackReport(t, np.zeros(2), R))
        core.update('/b', 'b', TrackReport(t, np.array([xb, 0.0]), R))
        return core.score(t)

    first = at(0.0, 0.0)
    (q,) = first.all_pairs()
    assert q.score == 1.0 and q.combined == 1.0 and q.associated and q.instants == 1
    (f,) = first.fused
    np.testing.assert_allclose(f.mu, [0.0, 0.0])
    np.testing.assert_allclose(f.P, R)  # CI of two equal estimates is the estimate
    (q,) = at(1.0, 100.0).all_pairs()  # ellipses do not intersect: instant score 0
    assert q.score == 0.0 and q.combined == 0.0 and not q.associated and q.instants == 2
    assert not core.score(1.0).fused
    (q,) = at(2.0, 0.0).all_pairs()
    assert q.instants == 2 and q.combined == 0.0  # the zero instant is still in the window of 2
    (q,) = at(3.0, 0.0).all_pairs()
    assert q.combined == 1.0 and q.associated


def test_a_floor_makes_one_disjoint_instant_evidence_not_a_veto():
    """floor ε: a true pair disjoint at one instant stays associated (ε^(1/n) in the geometric mean), listed
    with score 0 and fused; a pair never a candidate stays at 0 and unstored; K disjoint instants forget it."""
    core = PairAssociator('exact', threshold=0.5, combine='geometric', window=4, floor=FLOOR_2SIGMA)
    R = np.eye(2) * 4.0

    def at(t, xb):
        core.update('/a', 'a', TrackReport(t, np.zeros(2), R))
        core.update('/b', 'b', TrackReport(t, np.array([xb, 0.0]), R))
        core.update('/c', 'decoy', TrackReport(t, np.array([500.0, 500.0]), R))
        inst = core.score(t)
        return {(q.a, q.b): q for q in inst.all_pairs()}, inst

    for t in range(3):
        at(float(t), 0.0)
    pairs, inst = at(3.0, 100.0)                       # disjoint: exact score 0
    q = pairs[('a', 'b')]
    assert q.score == 0.0 and q.instants == 4
    assert math.isclose(q.combined, FLOOR_2SIGMA ** 0.25) and q.associated     # e^(-1/2) = 0.61
    assert [(f.a, f.b) for f in inst.fused] == [('a', 'b')]
    assert ('a', 'b') in [(p.a, p.b) for p in inst.pairs]  # passed to the window although not a candidate
    for p in ('a', 'b'):
        d = pairs[tuple(sorted((p, 'decoy')))]
        assert (d.combined, d.associated) == (0.0, False)
    assert set(core.history) == {('a', 'b')}           # the decoy's pairs are not stored
    pairs, _ = at(4.0, 100.0)                          # two disjoint instants of 4: ε^(1/2) = 0.37
    assert math.isclose(pairs[('a', 'b')].combined, FLOOR_2SIGMA ** 0.5) and not pairs[('a', 'b')].associated
    at(5.0, 100.0)
    pairs, _ = at(6.0, 100.0)                          # 4 disjoint instants: nothing speaks for the pair
    assert pairs[('a', 'b')].combined == 0.0 and core.history == {}
    pairs, _ = at(7.0, 0.0)                            # together again: ε³·1 over the window of 4
    assert math.isclose(pairs[('a', 'b')].combined, FLOOR_2SIGMA ** 0.75)
    with pytest.raises(ValueError, match='floor'):
        PairAssociator(floor=1.0)


def test_a_release_below_the_threshold_keeps_an_association_through_one_disjoint_instant():
    """Hysteresis: with the release ratio ε^(1/K) an associated pair outlasts one disjoint instant that
    takes its mean just below the threshold, not two; a pair never associated still needs the threshold;
    ratio 1 is the one-level rule."""
    K = 4
    ratio = release_ratio_of(FLOOR_2SIGMA, K)
    assert math.isclose(ratio, FLOOR_2SIGMA ** (1 / K))
    level = 0.5 * ratio

    def run(release_ratio, xs, start=0.0):
        core = PairAssociator('exact', threshold=0.5, combine='geometric', window=K, floor=FLOOR_2SIGMA,
                              release_ratio=release_ratio)
        R = np.eye(2) * 4.0
        out = []
        for t, xb in enumerate(xs):
            core.update('/a', 'a', TrackReport(start + t, np.zeros(2), R))
            core.update('/b', 'b', TrackReport(start + t, np.array([xb, 0.0]), R))
            (q,) = core.score(start + t).all_pairs()
            out.append((q.combined, q.associated))
        return out

    # 3.0 m apart: the 2σ circles (radius 4 m) overlap by ~0.5; 100 m: disjoint (floored at ε)
    near = run(1.0, [0.0])[0][0]
    assert near == 1.0
    part = run(1.0, [3.0])[0][0]
    xs = [0.0, 0.0, 3.0, 100.0, 3.0, 100.0, 100.0]
    one_level, held = run(1.0, xs), run(ratio, xs)
    for k, ((c1, a1), (c2, a2)) in enumerate(zip(one_level, held, strict=True)):
        assert c1 == c2                                     # the release changes no score
        assert a1 == (c1 >= 0.5) and a2 == (c2 >= 0.5 or (held[k - 1][1] and c2 >= level and c2 > 0))
    assert any(a2 and not a1 for (_, a1), (_, a2) in zip(one_level, held, strict=True))   # kept by the release
    assert not held[-1][1]                                  # two disjoint instants release it
    never = run(ratio, [100.0, 3.0, 3.0])                   # never associated: the threshold decides alone
    assert [a for _, a in never] == [c >= 0.5 for c, _ in never]
    assert part < 1.0
    with pytest.raises(ValueError, match='release'):
        PairAssociator(release_ratio=0.0)
    assert release_ratio_of(0.0, K) == 1.0


def test_a_prior_decides_a_young_pair_on_more_than_its_first_score():
    """With the prior (ν, s̄) a pair's first instant at g associates when (g·s̄^ν)^(1/(1+ν)) ≥ the threshold
    (here g ≈ 0.3 < 0.5), a never-overlapping pair stays at 0, ν = 0 is the paper's combination, the
    combined column carries the prior, the prior can change between instants (a live parameter), and
    the release ratio that keeps an association through one disjoint instant is ε^(1/(K + ν))."""
    K, nu, sbar = 4, 2.0, 0.8

    def run(xs, **kw):
        core = PairAssociator('exact', threshold=0.5, combine='geometric', window=K, floor=FLOOR_2SIGMA, **kw)
        R = np.eye(2) * 4.0
        out = []
        for t, xb in enumerate(xs):
            core.update('/a', 'a', TrackReport(float(t), np.zeros(2), R))
            core.update('/b', 'b', TrackReport(float(t), np.array([xb, 0.0]), R))
            (q,) = core.score(float(t)).all_pairs()
            out.append((q.score, q.combined, q.associated, q.instants))
        return out, core

    (first,), _ = run([4.0])                         # 2σ circles of radius 4 m, 4 m apart: score ~0.39
    assert 0.125 / sbar ** nu < first[0] < 0.5 and not first[2]
    (young,), _ = run([4.0], prior_weight=nu, prior_score=sbar)
    assert math.isclose(young[1], (first[0] * sbar ** nu) ** (1 / (1 + nu)), rel_tol=1e-12) and young[2]
    apart, _ = run([100.0, 100.0], prior_weight=nu, prior_score=sbar)
    assert [c for _, c, _, _ in apart] == [0.0, 0.0] and not any(a for *_, a, _ in apart)
    xs = [4.0, 0.0, 100.0, 4.0, 0.0, 0.0]
    plain, _ = run(xs)
    same, _ = run(xs, prior_weight=0.0, prior_score=sbar)
    assert plain == same
    with_p, core = run(xs, prior_weight=nu, prior_score=sbar)
    for (g, c, _, n), (g2, c2, _, n2) in zip(plain, with_p, strict=True):
        assert g == g2 and n == n2
        assert math.isclose(c2, math.exp((n * math.log(c) + nu * math.log(sbar)) / (n + nu)), rel_tol=1e-12)
    core.prior_weight = 0.0                          # the node's live parameter: the next instant without it
    core.update('/a', 'a', TrackReport(6.0, np.zeros(2), np.eye(2) * 4.0))
    core.update('/b', 'b', TrackReport(6.0, np.array([4.0, 0.0]), np.eye(2) * 4.0))
    (q,) = core.score(6.0).all_pairs()
    assert q.instants == K and math.isclose(q.combined, math.exp(np.mean(np.log(
        np.maximum([0.0 if x == 100.0 else (1.0 if x == 0.0 else first[0]) for x in [4.0, 0.0, 0.0, 4.0]],
                   FLOOR_2SIGMA)))), rel_tol=1e-9)
    assert math.isclose(release_ratio_of(FLOOR_2SIGMA, K, nu), FLOOR_2SIGMA ** (1 / (K + nu)))
    with pytest.raises(ValueError, match='prior'):
        PairAssociator(prior_weight=-1.0)
    with pytest.raises(ValueError, match='prior'):
        PairAssociator(prior_score=0.0)


def test_nothing_to_score_and_bad_settings():
    core = PairAssociator()
    assert core.score(0.0) is None
    core.update('/a', 'a', TrackReport(0.0, np.zeros(2), np.eye(2)))
    core.update('/a', 'b', TrackReport(0.0, np.zeros(2), np.eye(2)))
    assert core.score(0.0) is None  # one source only
    with pytest.raises(ValueError, match='method'):
        PairAssociator('bogus')
    with pytest.raises(ValueError, match='mean'):
        PairAssociator(combine='bogus')
    with pytest.raises(ValueError, match='threshold'):
        PairAssociator(threshold=1.5)


def test_stamp_schedule_scores_each_instant_once_with_the_reports_up_to_it():
    core = PairAssociator(stamp_rate=1.0)
    R = np.eye(2)
    assert core.push('/a', 'a', TrackReport(1.0, np.zeros(2), R)) == []
    assert core.push('/b', 'b', TrackReport(1.0, np.zeros(2), R)) == []
    (inst,) = core.push('/a', 'a', TrackReport(2.0, np.ones(2), R))
    assert inst.t == 1.0 and inst.ids == ['a', 'b'] and len(inst.all_pairs()) == 1
    np.testing.assert_array_equal(inst.mu, np.zeros((2, 2)))  # the 2 s report is not applied yet


@pytest.mark.parametrize('method', ['exact', 'glr', 'mc'])
@pytest.mark.parametrize('variance', [0.0, 5e-324])
def test_a_degenerate_track_is_skipped_and_every_other_pair_scored(method, variance):
    """Issue 13 defect 5: one zero/denormal covariance made score() raise and no pair was scored."""
    a = PairAssociator(method, n_samples=50)
    a.update('radar', 'r0', TrackReport(1.0, np.zeros(2), np.eye(2)))
    a.update('patrol', 'p0', TrackReport(1.0, np.array([0.5, 0.2]), np.diag([2.0, 1.0])))
    a.update('patrol', 'p1', TrackReport(1.0, np.array([40.0, 0.0]), np.eye(2)))
    a.update('ais', 'bad', TrackReport(1.0, np.array([3.0, 3.0]), np.diag([variance, variance])))
    inst = a.score(1.0)
    assert inst.error is None
    scored = {(q.a, q.b) for q in inst.all_pairs()}
    assert scored == {('r0', 'p0'), ('r0', 'p1')} and all(np.isfinite(q.score) for q in inst.all_pairs())
    assert {(x, y) for x, y, _ in inst.skipped} == {('r0', 'bad'), ('p0', 'bad'), ('p1', 'bad')}
    assert all('scoring failed' in why for _, _, why in inst.skipped)
    assert not any('bad' in key for key in a.history)  # a skipped pair's window is untouched


def test_valid_batches_take_the_batch_path_unchanged():
    """The isolation path only runs when the batch fails: a valid instant skips nothing."""
    a = PairAssociator('mc', n_samples=50)
    a.update('radar', 'r0', TrackReport(1.0, np.zeros(2), np.eye(2)))
    a.update('patrol', 'p0', TrackReport(1.0, np.array([0.5, 0.2]), np.diag([2.0, 1.0])))
    inst = a.score(1.0)
    assert inst.skipped == () and len(inst.all_pairs()) == 1


def _picture_run(gate: bool, combine: str, seed: int, rows_scored: list | None = None, floor: float = 0.0):
    """60 tracks of two sources in clusters, moving, some dropping out: every instant's pairs and fusions."""
    rng = np.random.default_rng(seed)
    core = PairAssociator('exact', 0.3, combine, 4, gate=gate, stale_after=1.5, floor=floor)
    centre = rng.uniform(0, 400.0, (60, 2))
    centre[30:] = centre[:30] + rng.normal(0, 3.0, (30, 2))       # source 2 sees the ships of source 1
    vel = rng.normal(0, 2.0, (60, 2))
    out = []
    for t in range(12):
        for k in np.flatnonzero(rng.random(60) > 0.1):
            a = rng.uniform(2.0, 30.0)
            c, s = np.cos(k + t), np.sin(k + t)
            U = np.array([[c, -s], [s, c]])
            R = U @ np.diag([a, a / rng.uniform(1, 6)]) @ U.T
            core.update('one' if k < 30 else 'two', f't{k}', TrackReport(float(t), centre[k] + vel[k] * t, R))
        inst = core.score(float(t))
        out.append([[q.a, q.b, q.score, q.combined, q.instants, q.associated] for q in inst.all_pairs()]
                   + [[f.a, f.b, f.mu.tolist(), f.P.tolist()] for f in inst.fused])
    return out


@pytest.mark.parametrize('combine', ['geometric', 'harmonic'])
@pytest.mark.parametrize('seed', [0, 1])
@pytest.mark.parametrize('floor', [0.0, FLOOR_2SIGMA])
def test_the_gate_changes_no_pair_result(combine, seed, floor, monkeypatch):
    import track_core.geofeasibility.gate as gate_mod

    scored = []
    real = gate_mod.score
    monkeypatch.setattr(gate_mod, 'score', lambda mu1, *a, **kw: scored.append(len(mu1)) or real(mu1, *a, **kw))
    gated = _picture_run(True, combine, seed, floor=floor)
    assert _picture_run(False, combine, seed, floor=floor) == gated
    assert sum(len(x) for x in gated) > 10 * sum(scored)         # most pairs were never scored
    assert any(q[3] > 0 for x in gated for q in x if len(q) == 6)  # and some pairs were associated
