import json
import subprocess
import sys

import pytest

from track_experiments.cli import RunConfig, bench_main, experiment_main, format_table, registry


def test_registries_hold_the_foundation_entries():
    assert 'demo-kf' in registry('experiment')
    assert {'kalman', 'recorder'} <= set(registry('bench'))


def test_experiment_quick_writes_json(tmp_path, capsys):
    out = tmp_path / 'r.json'
    code = experiment_main(['demo-kf', '--quick', '--seed', '3', '--runs', '20', '--json', str(out),
                            '--out', str(tmp_path), '--no-progress'])
    assert code == 0
    data = json.loads(out.read_text())
    assert data['name'] == 'demo-kf' and data['seed'] == 3 and data['runs'] == 20
    assert 2.0 < data['mean_anees'] < 6.0
    assert (tmp_path / 'demo-kf-anees.png').stat().st_size > 1000
    assert 'mean ANEES' in capsys.readouterr().out


def test_same_seed_same_result(tmp_path):
    args = ['demo-kf', '--quick', '--runs', '10', '--out', str(tmp_path), '--no-progress', '--json']
    experiment_main([*args, str(tmp_path / 'a.json')])
    experiment_main([*args, str(tmp_path / 'b.json')])
    assert json.loads((tmp_path / 'a.json').read_text()) == json.loads((tmp_path / 'b.json').read_text())


def test_bench_reports_a_ratio(tmp_path):
    out = tmp_path / 'b.json'
    assert bench_main(['kalman', '--quick', '--json', str(out)]) == 0
    data = json.loads(out.read_text())['kalman']
    assert all(v['speedup'] > 0 for v in data.values())


@pytest.mark.parametrize(('argv', 'words'), [
    (['no-such-entry'], 'unknown entry'),
    (['demo-kf', '--runs', '0'], '--runs must be >= 1'),
])
def test_bad_arguments_give_one_line_and_exit_2(argv, words):
    proc = subprocess.run([sys.executable, '-m', 'track_experiments.cli', *argv], capture_output=True, text=True)
    assert proc.returncode == 2
    assert words in proc.stderr and len(proc.stderr.strip().splitlines()) == 1
    assert 'Traceback' not in proc.stderr


def test_help_lists_entries():
    proc = subprocess.run([sys.executable, '-m', 'track_experiments.cli', '--help'], capture_output=True, text=True)
    assert proc.returncode == 0 and 'demo-kf' in proc.stdout and '--quick' in proc.stdout


def test_run_config_counts_and_table():
    assert RunConfig(quick=True).n_runs(100, 5) == 5
    assert RunConfig(runs=7, quick=True).n_runs(100, 5) == 7
    assert format_table(['a', 'b'], [[1, 0.123456]]).splitlines()[2].split() == ['1', '0.1235']


def test_set_options_reach_the_entry_and_the_json(tmp_path, monkeypatch):
    from importlib.metadata import EntryPoint

    from track_experiments import cli

    seen = {}

    @cli.set_keys(file='a file', k='a key')
    def fake(cfg):
        seen.update(cfg.options)
        return cli.Outcome('ok', {})

    monkeypatch.setattr(cli, 'registry', lambda kind: {'fake': EntryPoint('fake', 'x:y', 'g')})
    monkeypatch.setattr(EntryPoint, 'load', lambda self: fake)
    out = tmp_path / 'f.json'
    assert experiment_main(['fake', '--set', 'file=/a=b.csv', '--set', ' k =', '--json', str(out),
                            '--out', str(tmp_path)]) == 0
    assert seen == {'file': '/a=b.csv', 'k': ''}
    assert json.loads(out.read_text())['options'] == seen
    assert RunConfig().options == {}
    proc = subprocess.run([sys.executable, '-m', 'track_experiments.cli', 'demo-kf', '--set', 'novalue'],
                          capture_output=True, text=True)
    assert proc.returncode == 2 and 'KEY=VALUE' in proc.stderr


@pytest.mark.parametrize(('argv', 'words'), [
    (['geo-fig5', '--set', 'bogus=1'], ["unknown --set key 'bogus'", 'known: none']),
    (['ais-association', '--set', 'fil=x.csv'], ["'fil' (did you mean file?)"]),
])
def test_an_unknown_set_key_is_refused_with_the_closest_one(argv, words, tmp_path):
    proc = subprocess.run([sys.executable, '-m', 'track_experiments.cli', *argv, '--out', str(tmp_path / 'o')],
                          capture_output=True, text=True, timeout=120)
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 2 and len(lines) == 1 and 'Traceback' not in proc.stderr, proc.stderr
    assert all(w in lines[0] for w in words), lines[0]
    assert not (tmp_path / 'o').exists()  # refused before anything ran


def test_entry_help_lists_its_set_keys():
    proc = subprocess.run([sys.executable, '-m', 'track_experiments.cli', 'ais-association', '--help'],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0 and '--set keys of ais-association:' in proc.stdout, proc.stdout
    assert '  max_gap: ' in proc.stdout and '  file: ' in proc.stdout


def test_options_lists_every_key_with_its_meaning(capsys):
    from track_experiments.cli import experiment_main

    assert experiment_main(['ais-association', '--options']) == 0
    out = capsys.readouterr().out
    assert out.startswith('--set keys of ais-association:')
    for key in ('file', 'columns', 'max_distance_km', 'max_gap', 'radar_site', 'duration', 'sweep', 'prior_weight',
                'max_pairs'):
        line = next(x for x in out.splitlines() if x.startswith(f'  {key}: '))
        assert len(line) > len(key) + 12, line                             # a meaning, not just the name
    assert experiment_main(['--options']) == 0                             # every entry
    every = capsys.readouterr().out
    assert '--set keys of maritime-seeds:' in every and '--set keys of demo-kf:\n  (none' in every
    assert experiment_main(['no-such', '--options']) == 2


def test_a_choice_option_defaults_to_the_first_and_refuses_others():
    assert RunConfig().choice('prior', 'scenario', 'none') == 'scenario'
    assert RunConfig(options={'prior': 'none'}).choice('prior', 'scenario', 'none') == 'none'
    with pytest.raises(ValueError, match=r"--set prior='maybe': allowed scenario or none"):
        RunConfig(options={'prior': 'maybe'}).choice('prior', 'scenario', 'none')
