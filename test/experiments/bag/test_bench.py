"""``track-bench recorder --quick``: the recorder, the rclpy ceiling and the Writer are all measured.

Real rclpy and DDS; no timing is asserted, only that every figure exists, is positive and nothing was lost.
"""

from __future__ import annotations

import json

import pytest

from track_experiments.bag import bench
from track_experiments.cli import RunConfig

pytestmark = pytest.mark.integration


def test_quick_bench_reports_the_ceiling_and_the_ratios(tmp_path, monkeypatch, env_factory):
    monkeypatch.setattr(bench, '_domain_id', lambda: int(env_factory()['ROS_DOMAIN_ID']))
    out = bench.recorder_benchmark(RunConfig(quick=True, out=tmp_path, show_progress=False))
    for key in ('recorder_msgs_per_s', 'rclpy_ceiling_msgs_per_s', 'writer_msgs_per_s',
                'rclpy_events_executor_msgs_per_s', 'recorder_vs_rclpy_ceiling', 'recorder_vs_writer'):
        assert out.data[key] > 0, key
    assert out.data['recorder_lost'] == 0
    assert 'recorder / ceiling' in out.table
    json.dumps(out.data)
