import json

import numpy as np
import pytest

from track_experiments.cli import RunConfig, experiment_main
from track_experiments.geofeasibility.experiments import circle_overlap, fig2, fig5, fig6


def _cfg(tmp_path, **kw):
    return RunConfig(quick=True, out=tmp_path, show_progress=False, **kw)


def test_circle_overlap_closed_form():
    assert circle_overlap(1.0, 1.0, 0.0) == 1.0 and circle_overlap(1.0, 1.0, 2.0) == 0.0
    assert circle_overlap(1.0, 1.0, 1.0) == pytest.approx((2 * np.pi / 3 - np.sqrt(3) / 2) / np.pi)
    assert circle_overlap(2.0, 0.5, 1.0) == 1.0


def test_fig2(tmp_path):
    out = fig2(_cfg(tmp_path, runs=50))
    assert (tmp_path / 'geo-fig2.png').stat().st_size > 0
    assert out.data['trials'] == 50 and out.data['max_abs_exact_minus_analytic'] < 1e-9
    for r in out.data['rows']:
        assert abs(r['mc_mean'] - r['analytic']) <= 5 * r['mc_std'] / np.sqrt(50) + 1e-12


def test_fig5_slope_is_minus_3_db_per_doubling(tmp_path):
    out = fig5(_cfg(tmp_path, seed=3))
    assert set(out.data) == {'rows', 'db_per_doubling'}
    assert all(set(r) == {'n', 'mse'} for r in out.data['rows'])
    assert abs(out.data['db_per_doubling'] + 3.0) < 0.5
    assert (tmp_path / 'geo-fig5.png').exists()


def test_fig6(tmp_path):
    out = fig6(_cfg(tmp_path))
    mae = out.data['mae']
    assert out.data['pairs'] == 500
    assert mae['mc1000'] < 0.02 < mae['glr'] and mae['glr_thresholded'] <= mae['glr']
    assert sum(b['count'] for b in out.data['bins']) == 500
    assert (tmp_path / 'geo-fig6.png').exists()


def test_runner_writes_json(tmp_path, monkeypatch):
    from importlib.metadata import EntryPoint

    from track_experiments import cli

    ep = EntryPoint('geo-fig5', 'track_experiments.geofeasibility.experiments:fig5', 'track.experiments')
    monkeypatch.setattr(cli, 'registry', lambda kind: {'geo-fig5': ep})
    js = tmp_path / 'f5.json'
    assert experiment_main(['geo-fig5', '--quick', '--no-progress', '--out', str(tmp_path), '--json', str(js)]) == 0
    data = json.loads(js.read_text())
    assert {'rows', 'db_per_doubling'} <= set(data)
