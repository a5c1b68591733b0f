"""``track-experiment idsq-field --quick``: one process per sensor over simulated hosts records the
in-process track bit for bit; bring-up and CPU per step are reported and fitted.

Runs where the machine allows simulated hosts (root and ip netns; TRACK_TEST_HOSTS=0 opts out) and
skips with the reason elsewhere. The full 24/64/100-sensor run is the experiment's, not the suite's.
"""

from __future__ import annotations

import json
import os

import numpy as np
import pytest

from track_experiments.cli import RunConfig
from track_experiments.idsq.field import field, fit, hosts_for
from track_nodes.launch.hosts import unavailable

HOSTS_REASON = ('opted out: TRACK_TEST_HOSTS=0' if os.environ.get('TRACK_TEST_HOSTS') == '0'
                else unavailable())


@pytest.mark.integration
@pytest.mark.skipif(HOSTS_REASON is not None, reason=f'no simulated hosts: {HOSTS_REASON}')
def test_quick_field_over_two_hosts_records_the_in_process_track(tmp_path):
    out = field(RunConfig(quick=True, out=tmp_path, show_progress=False))
    rows = out.data['rows']
    assert [(r['sensors'], r['hosts'], r['processes']) for r in rows] == [(8, 2, 10), (16, 2, 18)]
    for r in rows:
        assert r['problem'] == '' and r['exit'] == 0, out.table
        assert r['bit_for_bit'] and r['max_abs_diff'] == 0.0 and r['estimates'] == r['steps'] == 10, r
        assert r['ready_s'] > 0 and r['cpu_s'] > 0 and r['namespaces_left'] == [], r
    assert out.data['all_bit_for_bit'] is True
    assert out.data['fit']['per_sensor_s'] is not None and 'CPU per step =' in out.table
    assert all(f.exists() for f in out.figures)
    json.dumps(out.data)


def test_fit_is_least_squares_and_end_to_end_slope():
    rows = [{'sensors': k, 'cpu_per_step_s': 0.05 + 0.002 * k} for k in (24, 64, 100)]
    f = fit(rows)
    assert np.isclose(f['intercept_s'], 0.05) and np.isclose(f['per_sensor_s'], 0.002)
    assert np.isclose(f['loglog_slope'], np.log(0.25 / 0.098) / np.log(100 / 24))
    assert f['sensors'] == [24, 64, 100]
    assert fit(rows[:1])['per_sensor_s'] is None  # one size: nothing to fit
    assert fit([*rows[:1], {'sensors': 64, 'cpu_per_step_s': None}])['per_sensor_s'] is None  # a failed run


def test_hosts_per_field_size():
    assert [hosts_for(k) for k in (8, 16, 24, 64, 100)] == [2, 2, 3, 7, 10]


@pytest.mark.parametrize('options, words', [({'sensors': '10'}, 'multiple of 4'), ({'sensors': 'a,b'}, 'integers'),
                                            ({'steps': '1'}, '>= 2'), ({'per_host': 'x'}, 'integer')])
def test_bad_options_are_one_line(tmp_path, options, words):
    with pytest.raises(ValueError, match=words):
        field(RunConfig(quick=True, out=tmp_path, show_progress=False, options=options))
