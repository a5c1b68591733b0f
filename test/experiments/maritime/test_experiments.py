"""``track-experiment maritime-seeds --quick``: the network goal on seeds 1-3 (simulated sources, replayed network)."""

import json

import pytest

from track_experiments.cli import RunConfig, experiment_main
from track_experiments.maritime.experiments import parse_seeds, seed_scenario


def test_quick_seeds_meet_the_network_goal(tmp_path, capsys):
    out = tmp_path / 'm.json'
    assert experiment_main(['maritime-seeds', '--quick', '--no-progress', '--json', str(out),
                            '--out', str(tmp_path)]) == 0
    data = json.loads(out.read_text())
    assert set(data['seeds']) == {'1', '2', '3'} and data['n_seeds'] == 3
    for s, r in data['seeds'].items():  # the goal: RTAMS <= 15 m, true pair >= 95 %, decoy never
        assert r['rtams'] <= 15.0 and r['fraction'] >= 0.95 and not r['decoy_ever'] and r['meets'], (s, r)
        assert r['instants'] >= 25
        assert 2 <= r['pings'] < 32  # the scenario's two initial pings, then eq. 7: not active at every step
    assert data['met'] == 3
    text = capsys.readouterr().out
    assert '3 of 3 seeds meet the goal' in text and 'worst RTAMS seed' in text and 'pings per run' in text


def test_seed_options():
    assert parse_seeds('1-3,7, 101-102') == [1, 2, 3, 7, 101, 102]
    with pytest.raises(ValueError, match='seeds'):
        parse_seeds('a-b')
    cfg = seed_scenario(5)
    assert cfg['/**/smart_target']['ros__parameters']['seed'] == 7
    assert cfg['/**/sonar_observer']['ros__parameters']['seed'] == 8
    assert RunConfig().options == {}


def test_an_unknown_key_is_refused(capsys):
    assert experiment_main(['maritime-seeds', '--quick', '--set', 'seed=4']) == 2
    assert 'seeds' in capsys.readouterr().err
