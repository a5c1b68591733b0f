"""Summary of the SLAM scenarios: path error, mode switches and the map."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from track_core.metrics import match_stamps
from track_nodes.report.maritime import start_when
from track_nodes.report.read import read_topics


def slam_metrics(bag: Path) -> list[str]:
    """SLAM scenarios (``slam_sim``, ``victoria_park``): path error, mode switches and the map.

    - With ``/slam/truth`` (slam_sim): position error of ``/slam/pose`` at the stamps that have a
      truth (final, RMSE and maximum) and the final heading error. The map frame is the truth's.
    - With ``/slam/gps`` (Victoria Park): RMSE against the GPS after the rigid alignment of
      ``track_core.slam.victoria.gps_rmse`` (the path interpolated at the GPS times, one least-squares
      rotation + translation, GPS jumps skipped).
    - Switches from ``/slam/events``; landmarks and counters from the last ``/slam/mode``.
    """
    from track_core.filters import wrap_angle
    from track_core.slam import victoria
    from track_msgs_py.odometry import odometry_to_pose
    from track_msgs_py.records.slam import SlamEvent, SlamMode
    from track_msgs_py.stamps import stamp_to_sec
    from track_msgs_py.topics import SLAM_EVENTS, SLAM_GPS, SLAM_MODE, SLAM_POSE, SLAM_TRUTH

    msgs = read_topics(bag, {SLAM_POSE, SLAM_TRUTH, SLAM_GPS, SLAM_EVENTS, SLAM_MODE})
    est = [odometry_to_pose(m) for m in msgs.get(SLAM_POSE, [])]
    if not est:
        return ['slam: no poses recorded']
    t_est = np.array([e[0] for e in est])
    x_est = np.array([e[1] for e in est])
    lines = [f'slam: {len(est)} poses over {t_est[-1] - t_est[0]:.1f} s from {start_when(t_est[0])}']
    truth = [odometry_to_pose(m) for m in msgs.get(SLAM_TRUTH, [])]
    if truth:
        it, ie = match_stamps(np.array([s[0] for s in truth]), t_est)
        if ie.size:
            x_true = np.array([s[1] for s in truth])[it]
            err = np.hypot(*(x_est[ie, :2] - x_true[:, :2]).T)
            head = abs(float(wrap_angle(x_est[ie[-1], 2] - x_true[-1, 2])))
            lines.append(f'  vs truth ({ie.size} stamps): final position error {err[-1]:.2f} m, heading '
                         f'{np.degrees(head):.2f} deg; RMSE {np.sqrt(np.mean(err**2)):.2f} m, max {err.max():.2f} m')
        else:
            lines.append('  vs truth: no pose stamp matches a truth stamp')
    gps = msgs.get(SLAM_GPS, [])
    if gps:
        g = np.array([[stamp_to_sec(m.header.stamp), m.point.x, m.point.y] for m in gps])
        try:
            rmse, _, used = victoria.gps_rmse(t_est, x_est[:, :2], g)
            lines.append(f'  vs GPS: RMSE {rmse:.2f} m after rigid alignment ({len(used)} of {len(g)} fixes, '
                         'jumps skipped)')
        except ValueError as exc:
            lines.append(f'  vs GPS: {exc}')
    events = _records(SlamEvent, msgs.get(SLAM_EVENTS, []))
    n_pf = sum(e.event == 'to_pf' for e in events)
    back = [e.pf_scans for e in events if e.event in ('to_cekf', 'pf_timeout')]
    timeouts = sum(e.event == 'pf_timeout' for e in events)
    line = f'  PF switches {n_pf}'
    if back:
        line += f', back to CEKF {len(back)} ({timeouts} by timeout), median {np.median(back):g} PF scans'
    modes = _records(SlamMode, msgs.get(SLAM_MODE, []))
    if modes:
        last = modes[-1]
        line += (f'; landmarks {last.landmarks}, scans {last.scans}, final mode {last.mode}; '
                 f'dropped observations {last.dropped_observations}, refused messages {last.refused_messages}')
    lines.append(line)
    return lines


def _records(cls, msgs) -> list:
    """The ``cls`` record of every message of ``msgs`` that holds one (others skipped)."""
    from track_msgs_py.records import RecordError

    out = []
    for m in msgs:
        try:
            out.append(cls.from_msg(m))
        except RecordError:
            continue
    return out
