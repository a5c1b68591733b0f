"""``track-experiment soak --quick``: three recorded runs at once, a looped bag, a field bring-up, all by SIGTERM."""

from __future__ import annotations

import pytest

from track_experiments.cli import RunConfig
from track_experiments.soak.experiments import soak_experiment

pytestmark = pytest.mark.integration


@pytest.fixture(scope='module')
def soak(tmp_path_factory, env_factory):
    cfg = RunConfig(quick=True, out=tmp_path_factory.mktemp('soak'), show_progress=False,
                    options={'domain': env_factory()['ROS_DOMAIN_ID']})
    return soak_experiment(cfg)


def test_every_part_survives_sigterm(soak):
    rows = soak.data['rows']
    assert [r['part'] for r in rows] == ['concurrent'] * 3 + ['loop', 'bringup']
    assert [r for r in rows if r['problem']] == [], soak.table
    assert soak.data['survived'] is True


def test_each_part_did_work(soak):
    for row in soak.data['rows']:
        assert row['messages'] > 0 and row['exit'] == 0, row
        assert row['ready_s'] is not None and row['stop_s'] is not None, row
    loop = next(r for r in soak.data['rows'] if r['part'] == 'loop')
    assert loop['run'].startswith('3 loops')


def test_bad_option_is_one_line(tmp_path):
    with pytest.raises(ValueError, match='--set loops=0: must be >= 1'):
        soak_experiment(RunConfig(quick=True, out=tmp_path, show_progress=False, options={'loops': '0'}))
    with pytest.raises(ValueError, match='unknown nope'):
        soak_experiment(RunConfig(quick=True, out=tmp_path, show_progress=False, options={'parts': 'nope'}))
