"""``track-bench fusion-shards``: real fusion nodes in processes; the shards' pairs equal the single node's."""

import json

from track_experiments.cli import bench_main
from track_experiments.fusion import shards_bench


def test_shards_publish_the_single_nodes_pairs(tmp_path):
    out = tmp_path / 'shards.json'
    assert bench_main(['fusion-shards', '--no-progress', '--set', 'tracks=400', '--set', 'ticks=6',
                       '--set', 'shards=2x1', '--json', str(out)]) == 0
    r = json.loads(out.read_text())
    assert r['shards'] == 2 and r['arrays_lost'] == 0
    assert r['instants_compared'] >= 3 and r['pairs_compared'] > 0 and r['associated'] > 0
    assert (r['max_abs_diff'], r['missing'], r['extra'], r['verdicts_differ']) == (0.0, 0, 0, 0)
    held = [s['live_tracks'] for s in r['per_shard']]
    assert all(0 < h < 400 for h in held) and sum(held) >= 400     # each holds its part and the margin


def test_compare_sees_a_shard_that_lost_a_pair():
    single = {'pairs': {(0.0, 'a', 'b'): (0.5, 0.5, 1, True), (0.0, 'c', 'd'): (0.2, 0.0, 1, False)}}
    shard = {'pairs': {(0.0, 'a', 'b'): (0.5, 0.25, 1, False)}}
    r = shards_bench.compare(single, [shard])
    assert (r['missing'], r['extra'], r['verdicts_differ'], r['max_abs_diff']) == (1, 0, 1, 0.25)
