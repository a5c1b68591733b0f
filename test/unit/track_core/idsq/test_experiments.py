import json

import numpy as np

from track_core.cli import RunConfig
from track_core.idsq.bench import bench
from track_core.idsq.experiments import selection, table4, table5


def test_table4_quick(tmp_path):
    out = table4(RunConfig(quick=True, runs=2, out=tmp_path, show_progress=False))
    assert set(out.data) == {'rows'}
    assert [r['sensors'] for r in out.data['rows']] == [24, 40, 64]
    per_prediction = {f'{v}_{k}' for v in ('drift', 'bank') for k in (
        'mmse_error_m', 'belief_spread_m2', 'belief_size', 'bytes_per_step', 'minus_diffusion_m',
        'minus_diffusion_2se_m')}
    assert all(set(r) == {'sensors', 'mmse_error_m', 'belief_spread_m2', 'belief_size', 'neighborhood_size',
                          'bytes_per_step', *per_prediction} for r in out.data['rows'])
    assert 'paper' in out.table and 'drift err m' in out.table and 'bank err m' in out.table
    assert all(f.exists() for f in out.figures)
    for r in out.data['rows']:  # handoff costs: header (+ 10 motion bytes) + 8 per cell; the bank's are joint
        assert r['bytes_per_step'] == 46 + 8 * r['belief_size']
        assert np.isclose(r['drift_bytes_per_step'], 56 + 8 * r['drift_belief_size'])
        assert r['bank_bytes_per_step'] > 52 + 8 * r['bank_belief_size']
    json.dumps(out.data)


def test_table5_quick(tmp_path):
    out = table5(RunConfig(quick=True, runs=2, out=tmp_path, show_progress=False))
    assert [r['doa_fraction'] for r in out.data['rows']] == [0.0, 0.5, 1.0]
    assert all(set(r) == {'doa_fraction', 'mmse_error_m', 'belief_spread_m2', 'belief_size'} for r in out.data['rows'])
    json.dumps(out.data)


def test_selection_quick(tmp_path):
    out = selection(RunConfig(quick=True, runs=2, out=tmp_path, show_progress=False))
    rows = {r['selection']: r for r in out.data['rows']}
    assert set(rows) == {'mi', 'nearest', 'random', 'centralized'}
    assert all(set(r) == {'selection', 'mmse_error_m', 'bytes_per_step'} for r in rows.values())
    assert rows['centralized']['mmse_error_m'] < rows['mi']['mmse_error_m']


def test_bench_quick():
    out = bench(RunConfig(quick=True, show_progress=False))
    assert set(out.data) == {'leader_step_ms', 'mi_loop_ms', 'centralized_step_ms'}
    assert all(v > 0 for v in out.data.values())
