"""Summary of the demo scenario: the Kalman track against the truth."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from track_core.metrics import match_stamps, mean_nees, rms
from track_msgs_py.odometry import odometry_to_cv_state
from track_msgs_py.topics import DEMO_TRACK, DEMO_TRUTH
from track_nodes.report.read import read_topics


def demo_metrics(bag: Path) -> list[str]:
    msgs = read_topics(bag, {DEMO_TRUTH, DEMO_TRACK})
    truth = [odometry_to_cv_state(m) for m in msgs.get(DEMO_TRUTH, [])]
    track = [odometry_to_cv_state(m) for m in msgs.get(DEMO_TRACK, [])]
    if not truth or not track:
        return ['demo: no truth/track pairs recorded']
    t_truth = np.array([s[0] for s in truth])
    t_track = np.array([s[0] for s in track])
    it, ie = match_stamps(t_truth, t_track)
    x_true = np.array([s[1] for s in truth])[it]
    x_est = np.array([s[1] for s in track])[ie]
    P_est = np.array([s[2] for s in track])[ie]
    err = x_true - x_est
    settled = slice(min(10, len(err) // 2), None)  # after the velocity prior is forgotten
    nees, undefined = mean_nees(err[settled], P_est[settled])
    unmatched = len(track) - len(ie)
    return [
        f'demo tracker: {len(ie)} estimates matched to truth'
        + (f'; left out: {unmatched} estimate(s) stamped at no truth time (reports from another publisher?)'
           if unmatched else ''),
        f'  position RMSE {rms(err[:, [0, 2]]):.3f} m, velocity RMSE {rms(err[:, [1, 3]]):.3f} m/s',
        f'  mean NEES {nees:.2f} (4 states; ≈4 when consistent, pos–vel cross-covariance not carried by '
        'Odometry)' + (f'; left out: {undefined} estimate(s) with a singular covariance' if undefined else ''),
    ]
