"""The ``maritime`` scenario's picture (``picture.png`` in the bag): the map, the pair scores, the errors.

The data come from ``report.maritime`` (``load``, ``tracker_errors``, ``verdicts``); times are
seconds from the run's start (``maritime.run_start``), the start shown once as a UTC date.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from track_core.filters import ellipse_points
from track_core.metrics import rms
from track_nodes.report.maritime import (
    NETWORK_TRACK,
    RADAR_DECOY,
    SONAR_TRACK,
    TRACKERS,
    run_start,
    start_when,
    tracker_errors,
    verdicts,
)

COLOURS = {SONAR_TRACK: 'tab:red', NETWORK_TRACK: 'tab:blue', RADAR_DECOY: 'tab:orange'}


def picture(d: dict, path: Path, errors: dict | None = None, v: dict | None = None, every: float = 5.0) -> Path:
    """One PNG: map (field, sensors, truth, tracks with 2σ ellipses every ``every`` s, pings) and timelines."""
    import matplotlib.pyplot as plt

    fig = figure(d, errors, v, every)
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path


def figure(d: dict, errors: dict | None = None, v: dict | None = None, every: float = 5.0):
    """The picture's matplotlib Figure (Agg), laid out; axes: map, scores, errors."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    errors = tracker_errors(d) if errors is None else errors
    v = verdicts(d, errors) if v is None else v
    start = run_start(d)
    fig = plt.figure(figsize=(15, 7.5), layout='constrained')  # makes room for the outside legends
    gs = fig.add_gridspec(2, 2, width_ratios=(1.15, 1.0))
    _map(fig.add_subplot(gs[:, 0]), d, every)
    ax1 = fig.add_subplot(gs[0, 1])
    _scores_panel(ax1, d, v, start)
    _errors_panel(fig.add_subplot(gs[1, 1], sharex=ax1), errors, start)
    return fig


def _map(ax, d: dict, every: float) -> None:
    s = d['sensors']
    if s is not None:
        doa = s['type'] == 1
        ax.scatter(s['x'][~doa], s['y'][~doa], marker='o', s=18, c='tab:cyan', label='acoustic sensor')
        ax.scatter(s['x'][doa], s['y'][doa], marker='^', s=26, c='tab:green', label='DOA sensor')
    truth_done = set()
    for track_id, (label, _, _, child) in TRACKERS.items():
        _, xt = d['truth'][track_id]
        if child not in truth_done and xt.size:
            truth_done.add(child)
            ax.plot(xt[:, 0], xt[:, 1], 'k-' if child != 't0' else 'k--', lw=1.2,
                    label='smart target truth' if child != 't0' else 'decoy truth')
        t, x, P = d['tracks'][track_id]
        if not t.size:
            continue
        c = COLOURS[track_id]
        ax.plot(x[:, 0], x[:, 1], '-', color=c, lw=0.9, alpha=0.8, label=f'{label} track')
        pick = np.flatnonzero(np.diff(np.floor(np.concatenate([[-np.inf], t]) / every)) > 0)  # one per interval
        for pts in ellipse_points(x[pick], P[pick], n_points=47):
            ax.plot(pts[:, 0], pts[:, 1], '-', color=c, lw=0.8)
    if d['observer'].size:
        ax.plot(d['observer'][:, 0], d['observer'][:, 1], ':', color='tab:purple', lw=1.2, label='observer AUV')
    if d['pings'].size:
        ax.scatter(d['pings'][:, 0], d['pings'][:, 1], marker='x', s=20, c='tab:purple', label='active ping')
    ax.set_aspect('equal')
    ax.set_xlabel('east [m]')
    ax.set_ylabel('north [m]')
    ax.set_title(f'map (2σ ellipses every {every:g} s)')
    ax.legend(fontsize=7, **LEGEND_BELOW)  # the map's tracks fill it: 'best' still covered some
    ax.grid(alpha=0.3)


# Lines that coincide (the decoy's two pairs both score 0; two trackers with the same error) stay
# visible: the k-th line of a panel is drawn narrower and with another dash than the one under it,
# and the instant dots use another marker, so a line on top of another leaves that one's edges showing.
LINE_STYLES = (('-', 3.0), ((0, (6, 2)), 2.0), ((0, (1, 2.5)), 1.4), ((0, (4, 1.5, 1, 1.5)), 1.0))
DOT_MARKERS = ('o', 'x', '+', '.')
LEGEND_OUTSIDE = {'loc': 'upper left', 'bbox_to_anchor': (1.01, 1.0), 'borderaxespad': 0.0}  # never over data
LEGEND_BELOW = {'loc': 'upper center', 'bbox_to_anchor': (0.5, -0.08), 'ncols': 3, 'borderaxespad': 0.0}


def line_style(k: int) -> dict:
    """Dash and width of a panel's k-th line (``LINE_STYLES``, cycled)."""
    ls, lw = LINE_STYLES[k % len(LINE_STYLES)]
    return {'ls': ls, 'lw': lw}


def _scores_panel(ax1, d: dict, v: dict, start: float) -> None:
    for k, ((a, b), rows) in enumerate(sorted(d['scores'].items())):
        name = f'{TRACKERS.get(a, (a,))[0]} | {TRACKERS.get(b, (b,))[0]}'
        verdict = 'associated' if v.get((a, b), {}).get('associated') else 'not associated'
        ax1.plot(rows[:, 0] - start, rows[:, 2], **line_style(k), label=f'{name}: {verdict}')
        ax1.plot(rows[:, 0] - start, rows[:, 1], ls='none', marker=DOT_MARKERS[k % len(DOT_MARKERS)], ms=3,
                 mfc='none', color=ax1.lines[-1].get_color(), alpha=0.6)
    ax1.axhline(0.5, color='grey', ls='--', lw=0.8)
    ax1.set_ylim(-0.03, 1.03)
    ax1.set_ylabel('score (line: combined, marks: instant)')
    ax1.set_title('fusion scores per pair (grey dashed: threshold)')
    ax1.legend(fontsize=7, **LEGEND_OUTSIDE)
    ax1.grid(alpha=0.3)


def _errors_panel(ax2, errors: dict, start: float) -> None:
    for k, (track_id, (t, err)) in enumerate(errors.items()):
        if t.size:
            ax2.plot(t - start, err, **line_style(k), color=COLOURS[track_id],
                     label=f'{TRACKERS[track_id][0]} (RTAMS {rms(err[:, None]):.1f} m)')
    ax2.set_xlabel(f"time from the run's start [s] (start: {start_when(start)})")
    ax2.set_ylabel('position error [m]')
    ax2.set_yscale('log')
    ax2.set_title('tracking error against truth')
    ax2.legend(fontsize=7, **LEGEND_OUTSIDE)
    ax2.grid(alpha=0.3)
