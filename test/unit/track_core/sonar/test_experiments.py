import json

from track_core.cli import RunConfig
from track_core.sonar.experiments import smart_target, table2


def test_table2_quick(tmp_path):
    out = table2(RunConfig(quick=True, runs=3, out=tmp_path, show_progress=False))
    assert set(out.data) == {'rows', 'baselines'}
    assert [r['delta'] for r in out.data['rows']] == [5.0, 10.0, 50.0, 100.0]
    assert all(set(r) == {'delta', 'active_epochs', 'rtams_m'} for r in out.data['rows'])
    assert set(out.data['baselines']) == {'papf', 'acpf'}
    acts = [r['active_epochs'] for r in out.data['rows']]
    assert acts[0] >= acts[2] >= acts[3]
    assert out.data['baselines']['papf']['rtams_m'] > out.data['baselines']['acpf']['rtams_m']
    assert all(f.exists() for f in out.figures)
    json.dumps(out.data)


def test_smart_target_quick(tmp_path):
    out = smart_target(RunConfig(quick=True, runs=2, out=tmp_path, show_progress=False))
    assert set(out.data['trackers']) == {'ss-pf', 'acpf', 'papf'}
    for v in out.data['trackers'].values():
        assert set(v) == {'pings', 'detections', 'first_detection_s', 'rtams_m'}
    assert out.data['trackers']['papf']['pings'] == 0
    assert out.data['trackers']['acpf']['pings'] == 40
    json.dumps(out.data)
