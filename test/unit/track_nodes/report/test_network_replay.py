"""``report.network_replay``'s summary and trace on synthetic rows (no bag, no ROS)."""

from __future__ import annotations

import numpy as np

from track_nodes.report import maritime as mar
from track_nodes.report import network_replay as nr

EPOCH = 1796283180.0  # a sim-time run's start: 2026-12-03 07:33:00 UTC

PAIR = tuple(sorted((mar.SONAR_TRACK, mar.NETWORK_TRACK)))


def _run(n: int = 8, collapsed: tuple[int, ...] = (3,), t0: float = 0.0):
    """Maritime data ``d``, replay rows and scores: the network beside the truth, its belief collapsed
    (all-zero covariance, one cell) at the steps ``collapsed``."""
    t = t0 + 1.0 + np.arange(n, dtype=float)
    truth = np.c_[np.zeros(n), 7.0 * np.arange(n)]
    rows = [{'t': float(t[k]), 'leader': 4, 'doa': False, 'range': 10.0, 'mean': truth[k] + [1.0, 0.0],
             'cov': np.zeros((2, 2)) if k in collapsed else 4.0 * np.eye(2), 'size': 1 if k in collapsed else 60,
             'bytes': 100, 'truth': truth[k]} for k in range(n)]
    d = {'tracks': {mar.SONAR_TRACK: (t, truth + np.array([0.0, 2.0]), np.tile(np.eye(2), (n, 1, 1))),
                    mar.RADAR_DECOY: (t, truth + np.array([500.0, 0.0]), np.tile(np.eye(2), (n, 1, 1)))},
         'truth': {mar.SONAR_TRACK: (t, truth), mar.NETWORK_TRACK: (t, truth),
                   mar.RADAR_DECOY: (t, truth + np.array([500.0, 0.0]))},
         'origin': t0, 'sensors': {'x': np.array([0.0, 20.0]), 'y': np.array([30.0, 30.0]),
                                   'type': np.array([0, 1])},
         'observer': np.zeros((0, 2)), 'pings': np.zeros((0, 2)), 'detections': 0}
    scores = {PAIR: np.c_[t, np.full(n, 0.9), np.full(n, 0.9), np.ones(n)],
              tuple(sorted((mar.RADAR_DECOY, mar.NETWORK_TRACK))): np.c_[t, np.zeros((n, 3))]}
    return d, rows, scores


def test_a_collapsed_belief_gives_nan_with_its_reason_not_a_crash():
    d, rows, scores = _run(collapsed=(3, 5))
    s = nr.summary(d, rows, scores)
    assert s['nees_undefined'] == 2
    t, why = s['nees_undefined_first']
    assert t == 4.0 and 'singular' in why  # step 3, stamped 4 s after the start
    assert s['nees_mean'] == 0.25  # error (1, 0), covariance 4 I: 1/4 at every defined step
    assert s['nees_over_6'] == 0.0
    note = nr.nees_note(s)
    assert 'undefined at 2 step(s)' in note and 'singular' in note
    nees, reasons = nr.belief_nees(rows)
    assert np.isnan(nees[[3, 5]]).all() and np.isfinite(np.delete(nees, [3, 5])).all()
    assert reasons[3] is not None and reasons[0] is None


def test_the_trace_marks_a_singular_step_instead_of_raising():
    _, rows, scores = _run(collapsed=(3,))
    lines = nr.trace_lines(rows, scores)
    assert len(lines) == len(rows)
    assert 'NEES  sing.' in lines[3] and 'nan' not in lines[3].lower()
    assert 'σ   0.0/ 0.0 m' in lines[3]
    assert 'NEES   0.2' in lines[0]


def test_no_note_when_every_nees_is_defined():
    d, rows, scores = _run(collapsed=())
    s = nr.summary(d, rows, scores)
    assert s['nees_undefined'] == 0 and s['nees_undefined_first'] is None and nr.nees_note(s) == ''


def test_the_trace_and_the_summary_give_seconds_from_an_epoch_start():
    d, rows, scores = _run(collapsed=(3,), t0=EPOCH)
    start = mar.run_start(d)
    assert start == EPOCH
    lines = nr.trace_lines(rows, scores, start)
    assert lines[0].startswith('t=  1.0 ') and lines[-1].startswith('t=  8.0 ')
    assert not any('1796' in ln or 'e+09' in ln for ln in lines)
    s = nr.summary(d, rows, scores)
    assert s['nees_undefined_first'][0] == 4.0
    assert mar.start_note(start) == "times in s from the run's start (2026-12-03 07:33:00 UTC)"
