"""The fusion scenario's nodes in-process: true pairs associated, the decoy never."""

from __future__ import annotations

FAST = {'radar': {'period': 0.05}, 'patrol': {'period': 0.1},
        'fusion': {'rate': 20.0, 'stale_after': 0.4, 'window': 10}}


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
    assert data['pairs_per_tick'] == 50 * 50 and data['cpu_share'] > 0 and data['reports_received_per_s'] > 0
