import json

import numpy as np

from track_experiments.cli import RunConfig
from track_experiments.sonar.bench import sonar_benchmark

KEYS = {'n200_ms', 'n2000_ms', 'transition_n200_ms', 'ukf_ms', 'smart_n200_ms', 'ukf_smart_ms',
        'smart_pf_over_ukf', 'scaling', 'merged', 'stonesoup_ukf_ms', 'filterpy_loop_n200_ms',
        'stonesoup_n200_ms', 'speedup_vs_filterpy', 'speedup_vs_stonesoup'}


def test_bench_json_keys(tmp_path):
    out = sonar_benchmark(RunConfig(quick=True, out=tmp_path, show_progress=False))
    assert set(out.data) == KEYS
    assert out.data['n200_ms'] > 0 and out.data['n2000_ms'] > 0 and out.data['ukf_ms'] > 0
    for peer, speedup in (('filterpy_loop_n200_ms', 'speedup_vs_filterpy'),
                          ('stonesoup_n200_ms', 'speedup_vs_stonesoup')):
        # a peer that is not installed is null, and so is its speed-up
        assert (out.data[peer] is None) == (out.data[speedup] is None)
    # on the CV target the default filter's mixture merges into one Gaussian
    assert out.data['merged']['steps_to_merge'] is not None and out.data['merged']['merged_ms'] > 0
    for prop in ('bootstrap', 'rb'):
        sc = out.data['scaling'][prop]
        assert [r['n'] for r in sc['rows']] == sorted(r['n'] for r in sc['rows'])
        assert all(r['cpu_s'] > 0 and r['peak_mb'] > 0 for r in sc['rows']) and np.isfinite(sc['loglog_slope'])
        # memory grows with N (the state is O(N))
        assert sc['rows'][-1]['peak_mb'] > sc['rows'][0]['peak_mb']
    json.dumps(out.data)
