"""``track-experiment soak --set parts=long``: the maritime scenario in one process and with ``--processes``,
its processes' RSS against data time and the outputs' pace per quarter.

The run here is short (60 data s per mode): it checks the report's structure and that every run
produced outputs at a pace > 0, not the goals (RSS slope, pace ratio). A slope fitted to a few
minutes after a warm-up of 15 s says nothing about a day; docs/results/operations.md has the long runs.
"""

from __future__ import annotations

import pytest

from track_experiments.cli import RunConfig
from track_experiments.soak.experiments import soak_experiment
from track_experiments.soak.long import MODES
from track_experiments.soak.probe import OUTPUTS

pytestmark = [pytest.mark.integration, pytest.mark.timeout(3600)]  # two runs of 46 nodes: minutes, more when loaded


@pytest.fixture(scope='module')
def soak(tmp_path_factory, env_factory):
    cfg = RunConfig(quick=True, out=tmp_path_factory.mktemp('soak'), show_progress=False,
                    options={'parts': 'long', 'data': '60', 'domain': env_factory()['ROS_DOMAIN_ID']})
    return soak_experiment(cfg)


def test_each_mode_ran_to_its_duration(soak):
    runs = soak.data['long']
    assert [r['mode'] for r in runs] == list(MODES)
    for r in runs:
        assert r['exit'] == 0 and not r['problem'], (r['problem'], soak.table)
        assert r['data_s'] >= 60 and r['outputs'] > 0 and isinstance(r['thinned'], list)


def test_every_quarter_has_outputs_at_a_pace(soak):
    for r in soak.data['long']:
        assert [q['quarter'] for q in r['quarters']] == [1, 2, 3, 4]
        for q in r['quarters']:
            assert q['wall_s'] > 0 and q['pace'] > 0 and q['per_wall_s'] > 0, q
            assert set(q['by_topic']) == set(OUTPUTS) and sum(q['by_topic'].values()) == q['outputs']
        assert r['pace_ratio'] > 0


def test_every_process_is_sampled(soak):
    inproc, procs = soak.data['long']
    assert [p['process'] for p in inproc['processes']] == ['launcher (every node)']
    names = {p['process'] for p in procs['processes']}
    assert {'launcher', 'fusion', 'vehicle_sim', 'sensor_0', 'sensor_39'} <= names, names
    for r in (inproc, procs):
        for p in r['processes']:
            assert p['rss_end'] > 0 and p['slope'] is not None, p
    assert 'slope MiB/data h' in soak.table and 'goals' in soak.table


def test_bad_modes_are_one_line(tmp_path):
    with pytest.raises(ValueError, match='--set modes: nope; choose from in-process, processes'):
        soak_experiment(RunConfig(quick=True, out=tmp_path, show_progress=False,
                                  options={'parts': 'long', 'modes': 'nope'}))
