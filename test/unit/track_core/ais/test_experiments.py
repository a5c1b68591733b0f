"""``track-experiment ais-association``: the --quick run through the runner, and the done-when F1 on the full file."""

import json

import pytest

from track_core.ais import ShipTruth
from track_core.ais.experiments import ORDER, Settings, run_once
from track_core.cli import experiment_main


@pytest.fixture(scope='module')
def quick_json(tmp_path_factory, solent):
    from importlib.metadata import EntryPoint

    from track_core import cli

    out = tmp_path_factory.mktemp('ais')
    ep = EntryPoint('ais-association', 'track_core.ais.experiments:ais_association', 'track.experiments')
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
    assert [s['scale'] for s in data['noise_sweep']] == [1.0, 4.0]
    assert (out / 'ais-association.png').stat().st_size > 0 and (out / 'ais-noise-sweep.png').stat().st_size > 0


def test_exact_reaches_f1_095_on_the_whole_file(solent):
    """Done when: exact reaches F1 ≥ 0.95 at the default source noise (one noise realisation here)."""
    res = run_once(ShipTruth(solent), seed=0, methods=('exact',), settings=Settings())
    m = res.methods['exact'].metrics
    print(f'exact: precision {m.precision:.3f} recall {m.recall:.3f} F1 {m.f1:.3f}, {len(res.pairs)} pairs')
    assert m.f1 >= 0.95
    assert res.methods['exact'].threshold_only.recall >= 0.95
