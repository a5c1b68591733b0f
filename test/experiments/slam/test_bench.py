"""``track-bench cekf`` and the CEKF/EKF equivalence it reports."""

import json

from track_experiments.cli import RunConfig
from track_experiments.slam.bench import cekf_bench, cekf_equivalence


def test_cekf_equals_full_ekf_after_global_update():
    assert cekf_equivalence(100, 400, seed=3) < 1e-9


def test_cekf_bench_quick(tmp_path):
    out = cekf_bench(RunConfig(quick=True, out=tmp_path, show_progress=False))
    assert set(out.data) == {'rows', 'max_abs_diff'}
    assert all(set(r) == {'landmarks', 'ekf_update_ms', 'cekf_update_ms', 'speedup'} for r in out.data['rows'])
    assert out.data['max_abs_diff'] < 1e-8
    json.dumps(out.data)
