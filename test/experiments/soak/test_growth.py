"""The long soak's arithmetic: an RSS slope per data hour after the warm-up, outputs per wall second per quarter."""

from __future__ import annotations

import os

import pytest

from track_experiments.soak.growth import Series, quarters, rss_cpu

NS = 1_000_000_000


def test_the_slope_is_mib_per_data_hour_after_the_warmup():
    s = Series('p', [(t, 500.0 if t < 900 else 300.0 + 6.0 * t / 3600, 0.0) for t in range(0, 3600, 60)])
    assert s.slope(900) == pytest.approx(6.0)  # the warm-up's 500 MiB is left out
    assert s.slope(3500) is None  # fewer than three samples after it


def test_quarters_count_outputs_by_stamp_and_divide_by_the_wall_time_of_the_quarter():
    epoch = 1_000 * NS
    clock = [(float(s) if s < 30 else 30 + 2.0 * (s - 30), s) for s in range(41)]  # the last quarter at half pace
    outputs = {'/a': [(0.0, epoch + s * NS) for s in range(40)], '/b': [(0.0, epoch + s * NS) for s in range(0, 40, 2)]}
    q = quarters(clock, outputs, epoch, 40.0)
    assert [r['wall_s'] for r in q] == [10.0, 10.0, 10.0, 20.0]
    assert [r['outputs'] for r in q] == [15, 15, 15, 15] and q[0]['by_topic'] == {'/a': 10, '/b': 5}
    assert q[3]['per_wall_s'] / q[0]['per_wall_s'] == pytest.approx(0.5) and q[3]['pace'] == pytest.approx(0.5)
    assert quarters(clock[:25], outputs, epoch, 40.0)[-1]['quarter'] == 2  # an unfinished quarter is not judged
    assert quarters([], outputs, None, 40.0) == []


def test_rss_and_cpu_of_this_process():
    rss, cpu = rss_cpu(os.getpid())
    assert rss > 10 and cpu > 0
