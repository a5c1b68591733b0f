"""The candidate-driven associator against a brute force: every pair scored, one ScoreWindow per pair.

Tracks of three sources wander over a small sea, report at random and drop out (stale) and come
back, so pairs leave and re-enter the gate's candidates and tracks' live intervals break. At every
instant ``all_pairs()`` must equal scoring every pair of different sources with the exact score and
combining each pair's window by its own ``ScoreWindow``: the same pairs, the same instant and
combined scores, window lengths and verdicts.
"""

from __future__ import annotations

import numpy as np
import pytest

from track_core.fusion import PairAssociator, TrackReport
from track_core.fusion.liveness import LiveIntervals
from track_core.geofeasibility import ScoreWindow, score


def _events(seed: int, n_ships: int = 6, steps: int = 60):
    """Each ship reported by three sources (a track each), at random, with noise; some ships cross."""
    rng = np.random.default_rng(seed)
    ship = rng.uniform(0, 40, (n_ships, 2))
    for step in range(steps):
        t = float(step)
        ship += rng.normal(0, 1.5, ship.shape)
        for k in np.flatnonzero(rng.random(3 * n_ships) < 0.7):   # a track skips reports and goes stale
            a = rng.uniform(2, 12)
            R = np.diag([a, rng.uniform(1, a)])
            mu = ship[k // 3] + rng.normal(0, 1.0, 2)
            yield 'r', t - 0.1, f'/s{k % 3}', f'/s{k % 3}/t{k}', TrackReport(t - 0.1, mu, R)
        yield 's', t


def _brute(events, window: int, combine: str, threshold: float):
    latest, src, wins, out = {}, {}, {}, []
    for ev in events:
        if ev[0] == 'r':
            _, _, source, tid, rep = ev
            latest[tid], src[tid] = rep, source
            continue
        t = ev[1]
        ids = [k for k, r in latest.items() if t - r.t <= 1.5]
        pairs = [(a, b) for x, a in enumerate(ids) for b in ids[x + 1:] if src[a] != src[b]]
        if not pairs:
            continue
        mu = {k: latest[k].mu for k in ids}
        R = {k: latest[k].R for k in ids}
        ordered = [(a, b) if tuple(mu[a]) <= tuple(mu[b]) else (b, a) for a, b in pairs]   # scored by position
        s = score(np.array([mu[a] for a, _ in ordered]), np.array([R[a] for a, _ in ordered]),
                  np.array([mu[b] for _, b in ordered]), np.array([R[b] for _, b in ordered]), 'exact')
        rows = []
        for (a, b), v in zip(pairs, np.atleast_1d(s), strict=True):
            w = wins.setdefault((a, b), ScoreWindow(combine, max_instants=window))
            w.add(t, float(np.clip(v, 0, 1)))
            c = w.value()
            rows.append((a, b, float(v), c, len(w), c >= threshold))
        out.append((t, rows))
    return out


@pytest.mark.parametrize('seed', range(6))
@pytest.mark.parametrize(('window', 'combine'), [(3, 'geometric'), (10, 'harmonic')])
def test_every_pair_equals_a_brute_force_window_per_pair(seed, window, combine):
    events = list(_events(seed))
    want = _brute(events, window, combine, 0.3)
    core = PairAssociator('exact', 0.3, combine, window, stale_after=1.5)
    got = []
    for ev in events:
        if ev[0] == 'r':
            core.update(ev[2], ev[3], ev[4])
        elif (inst := core.score(ev[1])) is not None:
            got.append((inst.t, [(q.a, q.b, q.score, q.combined, q.instants, q.associated)
                                 for q in inst.all_pairs()]))
            assert len(inst.pairs) <= len(inst.all_pairs())
            positive, live = {(q.a, q.b) for q in inst.pairs if q.score > 0}, set(inst.ids)
            assert all(p in positive or not set(p) <= live for p in core.history)   # no broken run is kept
    assert [t for t, _ in got] == [t for t, _ in want]
    for (t, g), (_, w) in zip(got, want, strict=True):
        assert g == w, t
    verdicts = [r[5] for _, rows in want for r in rows]
    assert 0 < sum(verdicts) < len(verdicts)          # both verdicts occur
    assert core.live.past                               # tracks did drop out and come back


def test_colive_counts_instants_both_tracks_were_live():
    live = LiveIntervals()
    for slots in ([0, 1], [0], [0, 1], [1, 2], [0, 1, 2]):
        live.mark(slots)
    # track 0: 0,1,2,4; track 1: 0,2,3,4; track 2: 3,4
    np.testing.assert_array_equal(live.colive([0, 0, 1], [1, 2, 2], 4), [3, 1, 2])
    np.testing.assert_array_equal(live.colive([0, 0, 1], [1, 2, 2], 2), [2, 0, 0])
