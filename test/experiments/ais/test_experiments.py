"""``track-experiment ais-association``: the --quick run through the runner, and the done-when F1 on the full file."""

import json

import pytest

from track_core.ais import ShipTruth
from track_experiments.ais.experiments import ORDER, Settings, run_once
from track_experiments.cli import experiment_main


@pytest.fixture(scope='module')
def quick_json(tmp_path_factory, solent):
    from importlib.metadata import EntryPoint

    from track_experiments import cli

    out = tmp_path_factory.mktemp('ais')
    ep = EntryPoint('ais-association', 'track_experiments.ais.experiments:ais_association', 'track.experiments')
    orig = cli.registry
    cli.registry = lambda kind: {'ais-association': ep}
    try:
        js = out / 'ais.json'
        code = experiment_main(['ais-association', '--quick', '--no-progress', '--out', str(out), '--json', str(js)])
    finally:
        cli.registry = orig
    assert code == 0
    return json.loads(js.read_text()), out


def test_quick_run_writes_the_json_keys_and_pngs(quick_json):
    data, out = quick_json
    assert {'ships', 'pairs_scored', 'methods'} <= set(data)
    assert set(data['methods']) == set(ORDER)
    for m in ORDER:
        for k in ('precision', 'recall', 'f1'):
            assert 0.0 <= data['methods'][m][k] <= 1.0, (m, k)
    assert 50 <= data['ships'] <= 91 and data['pairs_scored'] > 10_000
    assert data['rows_skipped'] == 4 and data['skipped'] == {'outside region': 1, 'duplicate': 3}
    assert data['warnings'] == [] and 0 < data['peak_rss_mb'] < 4000
    d = data['derived_defaults']
    assert d['region_rule'] == 'auto' and 33 < d['max_distance_km'] < 34
    assert d['gap']['rule'].startswith('derived') and d['gap']['limit_max_s'] == 3600.0
    assert d['radar_site']['rule'] == 'hull:280' and abs(d['radar_site']['lat_lon'][0] - 50.81) < 0.05
    assert data['settings']['prior_weight'] == 2.0 and data['chunks'] >= 1
    assert [x['prior_weight'] for x in data['short_pair_rule']] == [0.0, 2.0]
    assert [s['scale'] for s in data['noise_sweep']] == [1.0, 4.0]
    assert (out / 'ais-association.png').stat().st_size > 0 and (out / 'ais-noise-sweep.png').stat().st_size > 0


def test_exact_reaches_f1_095_on_the_whole_file(solent):
    """Done when: exact reaches F1 ≥ 0.95 at the default source noise (one noise realisation here)."""
    res = run_once(ShipTruth(solent), seed=0, methods=('exact',), settings=Settings())
    m = res.methods['exact'].metrics
    print(f'exact: precision {m.precision:.3f} recall {m.recall:.3f} F1 {m.f1:.3f}, {res.pair_instants} pairs')
    assert m.f1 >= 0.95
    assert res.methods['exact'].threshold_only.recall >= 0.95


def test_any_csv_through_the_runner(tmp_path):
    """A synthetic export of another sea (MarineCadastre columns): only its defects are discarded, defaults reported."""
    import numpy as np

    from track_core.ais.synthetic import synthetic_ais, write_csv

    src = write_csv(tmp_path / 'other.csv', synthetic_ais(np.random.default_rng(3), n_ships=30, duration=6 * 3600.0,
                                                          presence=0.6, n_duplicates=4, n_corrupt=2, n_bad=1),
                    'marinecadastre')
    from importlib.metadata import EntryPoint

    from track_experiments import cli

    ep = EntryPoint('ais-association', 'track_experiments.ais.experiments:ais_association', 'track.experiments')
    orig = cli.registry
    cli.registry = lambda kind: {'ais-association': ep}
    js = tmp_path / 'o.json'
    try:
        code = experiment_main(['ais-association', '--quick', '--no-progress', '--out', str(tmp_path), '--json',
                                str(js), '--set', f'file={src}', '--set', 'sweep=1', '--set', 'duration=7200'])
        bad = experiment_main(['ais-association', '--quick', '--no-progress', '--out', str(tmp_path),
                               '--set', 'colour=red'])
    finally:
        cli.registry = orig
    assert code == 0 and bad == 2
    data = json.loads(js.read_text())
    assert data['skipped'] == {'bad time': 1, 'outside region': 2, 'duplicate': 4}
    d = data['derived_defaults']
    assert d['columns']['time'] == 'BaseDateTime' and d['max_distance_km'] > 100
    assert 1000 < d['gap']['limit_median_s'] <= 3600 and d['gap']['gaps_bridged'] > 0.95
    lat, lon = d['radar_site']['lat_lon']
    assert abs(lat - 56.0) < 1.5 and abs(lon - 11.0) < 2.0                  # on this traffic, not at Calshot
    assert data['pairs_scored'] > 0 and data['methods']['exact']['tp'] > 0


def test_a_continent_wide_file_is_refused_in_one_line(tmp_path, capsys):
    """One report per ship across the Pacific: refused before any scoring, with the extent and what to do."""
    src = tmp_path / 'pacific.csv'
    src.write_text('BaseDateTime,MMSI,LAT,LON,COG,SOG\n' + ''.join(
        f'2023-01-01T00:{i:02d}:00,{367000000 + i},{20.0 + 2.0 * i},{-160.0 + 5.0 * i},90,10\n' for i in range(20)))
    code = experiment_main(['ais-association', '--quick', '--no-progress', '--out', str(tmp_path / 'o'),
                            '--set', f'file={src}', '--set', 'max_distance_km=off'])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and 'pacific.csv' in err[0] and 'split the file by region' in err[0], err
