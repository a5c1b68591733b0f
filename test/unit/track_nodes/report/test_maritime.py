"""The maritime summary and picture on synthetic data (no bag, no ROS)."""

from __future__ import annotations

import re
from itertools import pairwise

import numpy as np

from track_nodes.report import maritime as mar
from track_nodes.report import maritime_picture as pic
from track_nodes.report import maritime_summary as msum

EPOCH = 1796283180.0  # a sim-time run's start: 2026-12-03 07:33:00 UTC


def _data(t0: float = EPOCH, n: int = 40) -> dict:
    """Sonar and network on the smart target (converging from large errors), radar on the decoy; the decoy
    pairs score 0 throughout (their two lines coincide), the true pair 0.9."""
    t = t0 + 1.0 + np.arange(n, dtype=float)
    truth = np.c_[np.zeros(n), 7.0 * np.arange(n)]
    decoy = truth + np.array([400.0, 0.0])
    off = np.c_[np.zeros(n), 60.0 * np.exp(-np.arange(n) / 4.0) + 1.0]
    cov = np.tile(4.0 * np.eye(2), (n, 1, 1))
    zero = np.c_[t, np.zeros((n, 3))]
    return {'tracks': {mar.SONAR_TRACK: (t, truth + off, cov), mar.NETWORK_TRACK: (t, truth - off, cov),
                       mar.RADAR_DECOY: (t, decoy + 2.0, cov)},
            'truth': {mar.SONAR_TRACK: (t, truth), mar.NETWORK_TRACK: (t, truth), mar.RADAR_DECOY: (t, decoy)},
            'scores': {tuple(sorted((mar.SONAR_TRACK, mar.NETWORK_TRACK))): np.c_[t, np.full((n, 2), 0.9), np.ones(n)],
                       tuple(sorted((mar.RADAR_DECOY, mar.SONAR_TRACK))): zero,
                       tuple(sorted((mar.RADAR_DECOY, mar.NETWORK_TRACK))): zero.copy()},
            'sensors': {'x': np.array([0.0, 20.0]), 'y': np.array([30.0, 30.0]), 'type': np.array([0, 1])},
            'origin': t0, 'observer': np.c_[np.zeros(n), 7.0 * np.arange(n) - 50.0], 'pings': np.zeros((0, 2)),
            'detections': 0}


def test_a_summary_of_an_epoch_start_run_prints_small_times_and_the_date_once(tmp_path):
    lines = msum.summary_lines(_data(), tmp_path / mar.PICTURE)
    text = '\n'.join(lines)
    assert text.count('2026-12-03 07:33:00 UTC') == 1
    assert 'e+09' not in text and '1796' not in text
    conv = re.findall(r't=([0-9.]+) s', text)
    assert conv and all(float(c) < 100 for c in conv), conv  # 'converged' column: seconds from the start
    assert (tmp_path / mar.PICTURE).stat().st_size > 10_000, text


def test_run_start_without_a_layout_is_the_earliest_stamp():
    d = _data(t0=50.0)
    d['sensors'] = None
    assert mar.run_start(d) == 51.0
    assert mar.start_note(51.0) == "times in s from the run's start (clock t=51 s)"


def test_the_picture_time_axes_read_seconds_from_the_start_with_the_date_once():
    import matplotlib.pyplot as plt

    fig = pic.figure(_data())
    try:
        fig.canvas.draw()
        _, scores, errors = fig.axes
        for ax in (scores, errors):
            x = np.concatenate([ln.get_xdata() for ln in ax.lines if len(ln.get_xdata()) > 2])
            assert x.min() > 0.0 and x.max() < 100.0
            assert ax.xaxis.get_major_formatter().get_offset() == ''  # no '+1.7962828e9'
        labels = [ax.get_xlabel() + ax.get_title() for ax in fig.axes]
        assert sum('2026-12-03 07:33:00 UTC' in s for s in labels) == 1
    finally:
        plt.close(fig)


def test_the_legends_sit_outside_the_data_axes_and_inside_the_figure():
    import matplotlib.pyplot as plt

    fig = pic.figure(_data())
    try:
        fig.canvas.draw()
        r = fig.canvas.get_renderer()
        for ax in fig.axes:  # map (legend below it), scores, errors (legends right of them)
            lg, box = ax.get_legend().get_window_extent(r), ax.get_window_extent(r)
            assert lg.x0 >= box.x1 or lg.x1 <= box.x0 or lg.y0 >= box.y1 or lg.y1 <= box.y0, (ax.get_title(), lg, box)
            assert fig.bbox.contains(lg.x0, lg.y0) and fig.bbox.contains(lg.x1, lg.y1), (ax.get_title(), lg)
    finally:
        plt.close(fig)


def test_coinciding_score_lines_differ_in_dash_width_and_marker():
    """The decoy's two pairs both score 0 at every instant: one line on the other, so each must be told apart."""
    import matplotlib.pyplot as plt

    fig = pic.figure(_data())
    try:
        _, scores, errors = fig.axes
        combined = [ln for ln in scores.lines if not ln.get_label().startswith('_')]
        instant = [ln for ln in scores.lines if ln.get_marker() not in ('None', 'none', '', None)]
        assert len(combined) == 3 and len(instant) == 3
        zero = [ln for ln in combined if not np.any(ln.get_ydata())]
        assert len(zero) == 2  # the data really puts two lines on 0
        assert len({(ln.get_linestyle(), ln.get_linewidth()) for ln in combined}) == 3
        assert zero[0].get_linestyle() != zero[1].get_linestyle()
        assert zero[0].get_linewidth() != zero[1].get_linewidth()
        assert len({ln.get_marker() for ln in instant}) == 3
        err_lines = [ln for ln in errors.lines if not ln.get_label().startswith('_')]
        assert len({ln.get_linewidth() for ln in err_lines}) == len(err_lines) == 3
    finally:
        plt.close(fig)


def test_line_styles_cycle_with_distinct_neighbours():
    styles = [pic.line_style(k) for k in range(len(pic.LINE_STYLES) + 1)]
    assert all(a != b for a, b in pairwise(styles))
    assert styles[len(pic.LINE_STYLES)] == styles[0]
