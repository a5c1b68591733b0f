import json

from track_experiments.cli import RunConfig
from track_experiments.sonar.experiments import smart_target, table2


def test_table2_quick(tmp_path):
    out = table2(RunConfig(quick=True, runs=3, out=tmp_path, show_progress=False))
    assert {'rows', 'baselines', 'consistency', 'reading', 'peers'} <= set(out.data)
    assert [r['delta'] for r in out.data['rows']] == [5.0, 10.0, 50.0, 100.0]
    assert all({'delta', 'active_epochs', 'rtams_m', 'ukf'} <= set(r) for r in out.data['rows'])
    assert out.data['collapses_repaired'] == 0 and out.data['nees_undefined_steps'] == 0
    assert set(out.data['baselines']) == {'papf', 'acpf'}
    acts = [r['active_epochs'] for r in out.data['rows']]
    assert acts[0] >= acts[2] >= acts[3]
    assert out.data['baselines']['papf']['rtams_m'] > out.data['baselines']['acpf']['rtams_m']
    assert all(f.exists() for f in out.figures)
    json.dumps(out.data)


def test_table2_reading_option(tmp_path):
    out = table2(RunConfig(quick=True, runs=2, out=tmp_path, show_progress=False, reading='std,excess,position'))
    assert out.data['reading'] == 'std,excess,position,posterior'
    # the one-sided position reading with P_D as standard deviations lets δ = 5 go passive
    assert out.data['rows'][0]['active_epochs'] < 40


def test_smart_target_quick(tmp_path):
    out = smart_target(RunConfig(quick=True, runs=2, out=tmp_path, show_progress=False))
    assert {'ss-pf', 'ss-pf cv', 'ukf ss-pf', 'acpf', 'papf'} <= set(out.data['trackers'])
    for v in out.data['trackers'].values():
        assert set(v) == {'pings', 'detections', 'first_detection_s', 'rtams_m', 'anees'}
    assert [e['schedule'] for e in out.data['paired']][-1] == 'acpf'
    assert out.data['paired'][0]['pings'] == 0
    assert out.data['trackers']['papf']['pings'] == 0
    assert out.data['trackers']['acpf']['pings'] == 40
    json.dumps(out.data)


def test_cli_reading_flag(tmp_path, capsys):
    from track_experiments.cli import experiment_main

    out = tmp_path / 'r.json'
    assert experiment_main(['sonar-table2', '--quick', '--runs', '1', '--no-progress', '--out', str(tmp_path),
                            '--reading', 'std,excess,position', '--json', str(out)]) == 0
    data = json.loads(out.read_text())
    assert data['reading'] == 'std,excess,position,posterior'
    assert experiment_main(['sonar-table2', '--quick', '--runs', '1', '--no-progress', '--out', str(tmp_path),
                            '--reading', 'frobenius']) == 2
    assert 'unknown word' in capsys.readouterr().err


def test_wide_prior_quick(tmp_path):
    from track_experiments.sonar.experiments import WIDE_PRIOR_CASES, wide_prior

    out = wide_prior(RunConfig(quick=True, runs=4, out=tmp_path, show_progress=False))
    assert set(out.data['cases']) == {c[0] for c in WIDE_PRIOR_CASES}
    assert out.data['reference_particles'] == 2000
    for case in out.data['cases'].values():
        assert {'pf', 'ukf', 'reference', 'pf_minus_ukf_rms_m', 'pf_minus_ukf_se_m', 'pf_beats_ukf_by_2se'} <= set(case)
        assert case['pf']['in_band'], case  # the particle filter stays consistent on a wide prior
        # and follows the large bootstrap reference (the PF-vs-UKF verdict needs the full run's 100 runs)
        assert case['pf']['rtams_m'] < 1.5 * case['reference']['rtams_m'], case
    assert all(f.exists() for f in out.figures)
    json.dumps(out.data)
