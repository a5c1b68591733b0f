"""``track-bench fusion-scale``: the JSON schema, and max_abs_diff is a real comparison (never timings)."""

import json

import numpy as np
import pytest

from track_core.ais import default_path
from track_core.geofeasibility import ellipse_to_gaussian
from track_experiments.cli import bench_main
from track_experiments.fusion import bench

ROW_KEYS = {'tracks', 'pairs', 'candidate_pairs', 'gated_s', 'all_pairs_s', 'max_abs_diff', 'sampled'}


def _layout(n, seed=0):
    rng = np.random.default_rng(seed)
    rx = rng.uniform(5.0, 60.0, n)
    return ellipse_to_gaussian(*rng.uniform(0, 2000.0, (2, n)), rx, rx / rng.uniform(1, 4, n), rng.uniform(0, 3, n))


@pytest.mark.skipif(not default_path().is_file(), reason=f'shared AIS data not found: {default_path()}')
def test_quick_bench_writes_the_issue_schema_with_identical_scores(tmp_path):
    out = tmp_path / 'scale.json'
    assert bench_main(['fusion-scale', '--quick', '--json', str(out)]) == 0
    rows = json.loads(out.read_text())['rows']
    assert [r['tracks'] for r in rows] == [100, 1000]
    for r in rows:
        assert set(r) >= ROW_KEYS
        assert r['pairs'] == r['tracks'] * (r['tracks'] - 1) // 2
        assert 0 < r['candidate_pairs'] < r['pairs']
        assert r['gated_s'] > 0 and r['all_pairs_s'] > 0
        assert r['max_abs_diff'] == 0.0
    assert rows[0]['sampled'] is False and rows[1]['sampled'] is True and rows[1]['sample_pairs'] == 20_000


@pytest.mark.parametrize('sample', [None, 3000])
def test_a_row_compares_every_pair_or_a_sample(sample):
    mu, R = _layout(300)
    row = bench.scale_row(mu, R, 1, np.random.default_rng(0), sample)
    assert row['max_abs_diff'] == 0.0 and row['sampled'] is (sample is not None)
    assert row['pairs'] == 300 * 299 // 2 and 0 < row['candidate_pairs'] < row['pairs']


def test_max_abs_diff_sees_a_gate_that_drops_an_overlapping_pair(monkeypatch):
    mu, R = _layout(300)
    real = bench.candidate_pairs

    def lossy(mu, R):
        i, j = real(mu, R)
        return i[1:], j[1:]

    monkeypatch.setattr(bench, 'candidate_pairs', lossy)
    assert bench.scale_row(mu, R, 1, np.random.default_rng(0), None)['max_abs_diff'] > 0.0


def test_sampled_pairs_are_distinct_and_ordered():
    i, j = bench._sample_pairs(50, 1000, np.random.default_rng(1))
    assert i.size == 1000 and np.all(i < j) and np.unique(i * 50 + j).size == 1000
