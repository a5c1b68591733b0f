"""Shard regions: a tiling gives every pair one owner, and shards with the needed margin equal one associator."""

from __future__ import annotations

import math

import numpy as np
import pytest

from track_core.fusion import PairAssociator, TrackReport
from track_core.fusion.region import Region, ShardInput, grid, margin_needed

WINDOW, STALE = 5, 1.5


def test_a_grid_tiles_the_plane_and_owns_each_pair_once():
    regions = grid(0.0, 100.0, 0.0, 50.0, 3, 2, margin=10.0)
    rng = np.random.default_rng(0)
    a, b = rng.uniform(-50, 150, (2, 1000, 2))
    owners = np.sum([r.owns(a, b) for r in regions], axis=0)
    assert np.all(owners == 1)
    assert regions[0].xmin == -math.inf and regions[-1].xmax == math.inf


def test_contains_widens_the_rectangle_by_the_margin():
    r = Region(0.0, 10.0, 0.0, 10.0, margin=2.0)
    assert r.contains(-2.0, 5.0) and r.contains(11.9, 11.9) and not r.contains(12.0, 5.0)
    assert not r.owns(np.array([[11.0, 5.0]]), np.array([[11.0, 5.0]]))[0]
    with pytest.raises(ValueError, match='xmin < xmax'):
        Region(1.0, 0.0)
    with pytest.raises(ValueError, match='xmin, xmax, ymin, ymax'):
        Region.parse([0.0, 1.0], 0.0)
    assert Region.parse([], 3.0) == Region(margin=3.0)


def _sea(rng, n_ships: int, steps: int, speed: float):
    """Ships crossing a 600 m square, each reported by two sources (a track each) every second."""
    pos = rng.uniform(0, 600, (n_ships, 2))
    vel = rng.normal(0, speed, (n_ships, 2))
    for k in range(steps):
        pos += vel
        for s, sigma in (('/r', 4.0), ('/p', 9.0)):
            for i in range(n_ships):
                R = np.diag([sigma**2, (sigma / 2) ** 2])
                yield s, f'{s}/t{i}', TrackReport(float(k), pos[i] + rng.normal(0, sigma / 2, 2), R)


def _pairs(inst, keep=None) -> dict:
    """(t, sorted ids) → (score, combined, instants, associated) of the nonzero pairs (a shard orders a pair
    by when its tracks entered the shard)."""
    q = inst.pairs
    m = (q.score > 0) | (q.combined > 0) | q.associated
    if keep is not None:
        m &= keep(inst)
    return {(inst.t, *sorted((inst.ids[a], inst.ids[b]))): (s, c, n, v) for a, b, s, c, n, v in
            zip(q.ia[m], q.ib[m], q.score[m], q.combined[m], q.instants[m], q.associated[m], strict=True)}


@pytest.mark.parametrize('seed', range(3))
def test_shards_with_the_needed_margin_give_one_associators_pairs(seed):
    rng = np.random.default_rng(seed)
    v_max = 4.0
    margin = margin_needed(r_max=2 * 9.0, v_max=v_max * 1.5, window=WINDOW, rate=1.0, stale_after=STALE)
    regions = grid(0.0, 600.0, 0.0, 600.0, 2, 2, margin)

    def core():
        return PairAssociator('exact', 0.3, 'geometric', WINDOW, stale_after=STALE, stamp_rate=1.0)

    single, shards = core(), [(ShardInput(r), core()) for r in regions]
    want, got, dropped = {}, {}, 0
    for source, tid, rep in _sea(rng, 60, 40, v_max / 2):
        for inst in single.push(source, tid, rep):
            want |= _pairs(inst)
        for shard, c in shards:
            route = shard.route(tid, *rep.mu)
            dropped += route == 'drop'
            if route != 'skip':
                for inst in c.push(source, tid, rep if route == 'hold' else None, t=rep.t):
                    owned = shard.region.owns
                    got |= _pairs(inst, lambda i, owned=owned: owned(i.mu[i.pairs.ia], i.mu[i.pairs.ib]))
    assert dropped > 0                             # tracks did leave shards (and were forgotten)
    assert sum(v[3] for v in want.values()) > 10   # pairs associated
    assert got == want


def test_too_small_a_margin_is_seen():
    """With no margin a shard loses pairs across its edge: the comparison above can fail."""
    rng = np.random.default_rng(0)
    regions = grid(0.0, 600.0, 0.0, 600.0, 2, 2, 0.0)
    single = PairAssociator('exact', 0.3, 'geometric', WINDOW, stale_after=STALE, stamp_rate=1.0)
    shards = [(ShardInput(r), PairAssociator('exact', 0.3, 'geometric', WINDOW, stale_after=STALE, stamp_rate=1.0))
              for r in regions]
    want, got = {}, {}
    for source, tid, rep in _sea(rng, 60, 20, 2.0):
        for inst in single.push(source, tid, rep):
            want |= _pairs(inst)
        for shard, c in shards:
            route = shard.route(tid, *rep.mu)
            if route != 'skip':
                for inst in c.push(source, tid, rep if route == 'hold' else None, t=rep.t):
                    owned = shard.region.owns
                    got |= _pairs(inst, lambda i, owned=owned: owned(i.mu[i.pairs.ia], i.mu[i.pairs.ib]))
    assert got != want
