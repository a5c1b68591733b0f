import json

import pytest

from track_core.cli import RunConfig
from track_core.slam import victoria
from track_core.slam.experiments import cekf_bench, victoria_park


def test_cekf_bench_quick(tmp_path):
    out = cekf_bench(RunConfig(quick=True, out=tmp_path, show_progress=False))
    assert set(out.data) == {'rows', 'max_abs_diff'}
    assert all(set(r) == {'landmarks', 'ekf_update_ms', 'cekf_update_ms', 'speedup'} for r in out.data['rows'])
    assert out.data['max_abs_diff'] < 1e-8
    json.dumps(out.data)


@pytest.mark.skipif(not victoria.data_dir().is_dir(), reason='Victoria Park data not available')
def test_victoria_park_quick(tmp_path):
    out = victoria_park(RunConfig(quick=True, out=tmp_path, show_progress=False))
    assert set(out.data) == {'gps_rmse_m', 'landmarks', 'pf_switches', 'runtime_s', 'duration_s'}
    assert out.data['gps_rmse_m'] < 5.0 and out.data['landmarks'] > 20
    assert all(f.exists() for f in out.figures)
