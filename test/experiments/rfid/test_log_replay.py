"""``track-experiment rfid-reader --set file=LOG.csv``: the shipped log instead of the simulation; bad keys and
bad logs refused with one line (exit code 2)."""

from __future__ import annotations

import json
from pathlib import Path

from track_experiments.cli import experiment_main

REPO = Path(__file__).resolve().parents[3]
EXAMPLE = REPO / 'data/rfid/example-walk.csv'


def test_the_example_log_replaces_the_simulation(tmp_path, capsys):
    out = tmp_path / 'r.json'
    code = experiment_main(['rfid-reader', '--set', f'file={EXAMPLE}', '--no-progress', '--out', str(tmp_path),
                            '--json', str(out)])
    assert code == 0, capsys.readouterr().err
    data = json.loads(out.read_text())
    assert data['log']['moves'] == 8 and data['log']['truth'] and data['options'] == {'file': str(EXAMPLE)}
    assert 'sign' not in data                       # the simulation did not run
    assert data['kept']['ours'] == 1.0 and data['median_error']['ours'] < 0.05
    pfb = data['pf_batch']
    assert pfb['moves'] == 8 and pfb['batch_error_m'] < 0.2 and pfb['pf_error_m'] < 0.5
    assert 'example-walk.csv: tag E2' in capsys.readouterr().out


def test_unknown_keys_and_bad_logs_are_refused(tmp_path, capsys):
    assert experiment_main(['rfid-reader', '--set', f'fil={EXAMPLE}', '--no-progress']) == 2
    assert "unknown --set key 'fil' (did you mean file?)" in capsys.readouterr().err
    assert experiment_main(['rfid-reader', '--set', 'epc=E200', '--no-progress', '--quick']) == 2
    assert '--set epc needs --set file=LOG.csv' in capsys.readouterr().err
    bad = tmp_path / 'bad.csv'
    text = EXAMPLE.read_text().splitlines()
    fields = text[12].split(',')
    fields[5] = 'nan'                               # the phase of a read
    text[12] = ','.join(fields)
    bad.write_text('\n'.join(text) + '\n')
    assert experiment_main(['rfid-reader', '--set', f'file={bad}', '--no-progress']) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith('track-experiment rfid-reader: bad.csv: line 13, column phase: ') and '\n' not in err
    assert experiment_main(['rfid-reader', '--set', f'file={tmp_path / "none.csv"}', '--no-progress']) == 2
    assert 'none.csv' in capsys.readouterr().err
