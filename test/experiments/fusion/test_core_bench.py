"""``track-bench fusion-core``: the schema, and the identity check against the brute force can fail."""

import json

import numpy as np
import pytest

from track_core.fusion import associator
from track_experiments.cli import bench_main
from track_experiments.fusion import core_bench
from track_experiments.fusion.sea import SyntheticSea


def test_quick_bench_reports_rows_slope_and_identity(tmp_path):
    out = tmp_path / 'core.json'
    assert bench_main(['fusion-core', '--quick', '--no-progress', '--json', str(out)]) == 0
    sea = json.loads(out.read_text())['sea']
    assert [r['tracks'] for r in sea['rows']] == list(core_bench.SEA_QUICK)
    first = sea['rows'][0]
    assert first['max_abs_diff'] == 0.0 and first['verdicts_equal'] is True
    assert 0 < first['associated'] <= first['positive_pairs'] <= first['candidates']
    assert all(r['live_tracks'] == r['tracks'] and r['tick_s'] > 0 for r in sea['rows'])
    assert isinstance(sea['slope'], float)


def test_a_gate_that_loses_a_candidate_is_caught(monkeypatch):
    real = associator.candidate_pairs

    def lossy(mu, R):
        i, j = real(mu, R)
        return i[1:], j[1:]

    monkeypatch.setattr(associator, 'candidate_pairs', lossy)
    row = core_bench.run_layout(SyntheticSea(200, np.random.default_rng(3)), 4, True)
    assert row['max_abs_diff'] > 0.0


def test_slope_fits_the_rows_above_the_floor():
    rows = [{'tracks': n, 'tick_s': 1e-6 * n**1.5} for n in (100, 1000, 2000, 8000)]
    assert core_bench.slope(rows, 1000) == pytest.approx(1.5)
    assert core_bench.slope(rows[:2], 1000) is None
