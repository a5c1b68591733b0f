"""``track-bench fusion-node``: the real node on every published track, and a run that did not hold them flagged."""

from __future__ import annotations


def test_fusion_node_bench_runs_the_node_on_every_track(tmp_path):
    """``track-bench fusion-node`` (small): the node scored ticks holding every published track; no timing asserted."""
    import json

    import pytest

    from track_core.ais import default_path
    from track_experiments.cli import bench_main

    if not default_path().is_file():
        pytest.skip(f'shared AIS data not found: {default_path()}')
    out = tmp_path / 'node.json'
    assert bench_main(['fusion-node', '--quick', '--set', 'tracks=100', '--set', 'seconds=3', '--json', str(out)]) == 0
    data = json.loads(out.read_text())
    assert data['tracks'] == 100 and data['ticks'] >= 2 and data['live_tracks_max'] == 100
    assert data['held_every_track'] == (data['ticks_holding_every_track'] == data['ticks'])
    assert 0 < data['pairs_per_tick'] <= 50 * 50 and data['cpu_share'] > 0 and data['reports_received_per_s'] > 0


def test_a_run_that_did_not_hold_every_track_is_flagged():
    """Ticks with fewer live tracks than published: held_every_track is false (the table says NOT HELD)."""
    from types import SimpleNamespace

    from track_experiments.fusion.node_bench import _figures

    probe = SimpleNamespace(ticks=[(1.0, 100, 4950, 10, 0.1), (2.0, 67, 2211, 5, 0.1), (3.0, 100, 4950, 10, 0.1)])
    held = _figures(probe, 0.0, 10.0, 100)
    assert held['ticks'] == 3 and held['ticks_holding_every_track'] == 2 and not held['held_every_track']
    assert _figures(probe, 2.5, 10.0, 100)['held_every_track']
