"""The ``maritime`` scenario: sonar, sensor network and fusion in one picture.

What runs (``config/maritime.yaml``, written by ``scenario_yaml`` below):

- ``smart_target`` crosses the seabed field of the IDSQ network from south to north (cruise
  7 m/s, evading at up to 12 m/s when it hears a ping: below the network's v_max = 15 m/s);
  truth on ``/sonar/target/truth``.
- ``sonar_observer`` (the AUV, SS-PF + eq. 7 covariance-control scheduling) follows it from the
  south and pings it; track ``/sonar/estimate`` (child ``sonar_track``).
- ``vehicle_sim`` publishes only the sensor layout (``publish_truth: false``); one
  ``acoustic_sensor``/``doa_sensor`` node per sensor, with ``truth_topics`` = the smart target's
  and the decoy's truth: each sensor senses the loudest (nearest) source, so the network tracks
  whatever is loudest in its field with IDSQ; track ``/idsq/estimate`` (child ``idsq_track``).
  The sensors predict with the velocity-hypothesis bank (``prediction: bank``,
  ``track_core.idsq.prediction``) on a grid reaching 300 m north, with a 60 m radio range (the
  §5.1 40 m leaves a third of the links between adjacent columns out, ``launch.generate``).
  The decoy sails well east of the field, so the loudest source in the field is the smart target.
  Every node steps at Δt = T = 1 s: the truth stamped k·T is the network's step k − 1.
- ``report_source`` named ``radar``: a coastal radar that sees only the decoy, a constant-velocity
  vessel on its own course that nobody pings; truth ``/radar/truth`` (child ``t0``), reports
  ``/radar/t0`` with 2σ ellipses.
- ``fusion`` scores the three pairs at the data instants k·1 s (``schedule: stamps``, so a
  replay of the bag into a fresh fusion node gives the same scores), publishes scores,
  associations, fused estimates and markers.

Evaluation (``maritime_metrics``, registered as ``SCENARIO_METRICS['maritime']``, run by the
launcher after a recorded run): per tracker RTAMS (l = 0: √ mean squared position error over the
matched stamps) against its target's truth; pings emitted (``/sonar/ping``) and detected (the
target's last status); per pair the mean instant score and the verdict. The verdict of a pair is
"associated" when the fusion associated it at ≥ half of its scored instants after *both* trackers
converged, a tracker having converged from the first stamp its position error is below
``CONVERGED_M`` (an evaluation-only choice; the fusion node never sees the truth); the summary
prints the true pair's fraction (the goal: ≥ 95 %) and whether a decoy pair was ever associated. It also writes
``picture.png`` into the bag directory (``picture``).

Times printed or drawn are seconds from the run's start (``run_start``: the network's step origin,
else the earliest stamp), not clock stamps: a sim-time run starts at an epoch (~1.8e9 s), whose
raw stamps read ``t=1.79628e+09``. The start itself is shown once, as a UTC date (``start_note``).
"""

from __future__ import annotations

from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from track_core.filters import ellipse_points
from track_core.metrics import match_stamps, rms
from track_msgs_py.clouds import pointcloud2_to_table
from track_msgs_py.odometry import odometry_to_cv_state, pose_cov_to_position
from track_msgs_py.records.fusion import FusionPairs
from track_msgs_py.stamps import stamp_to_sec
from track_msgs_py.topics import (
    FUSION_SCORES,
    IDSQ_ESTIMATE,
    IDSQ_LAYOUT,
    SONAR_ESTIMATE,
    SONAR_OBSERVER,
    SONAR_PING,
    SONAR_TARGET_STATUS,
    SONAR_TRUTH,
)
from track_nodes.report.read import read_topics

RADAR_TRUTH = '/radar/truth'
RADAR_DECOY = '/radar/t0'
SONAR_TRACK = f'{SONAR_ESTIMATE}/sonar_track'
NETWORK_TRACK = f'{IDSQ_ESTIMATE}/idsq_track'
# Fusion track id → (label, estimate topic, truth topic, truth child_frame_id).
TRACKERS = {
    SONAR_TRACK: ('sonar (SS-PF)', SONAR_ESTIMATE, SONAR_TRUTH, 'smart_target'),
    NETWORK_TRACK: ('network (IDSQ)', IDSQ_ESTIMATE, SONAR_TRUTH, 'smart_target'),
    RADAR_DECOY: ('radar', RADAR_DECOY, RADAR_TRUTH, 't0'),
}
CONVERGED_M = 20.0  # a tracker has converged from the first stamp its position error is below this [m]
PICTURE = 'picture.png'
EPOCH_MIN = 1e8  # a start stamp above this [s] (1973 on) is a calendar time, shown as a UTC date


# --- reading the bag ------------------------------------------------------------------------------

def _states(msgs: list, child: str | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Odometry list → (t (n,), xy (n, 2), P (n, 2, 2)), optionally only one child_frame_id."""
    rows = [odometry_to_cv_state(m) for m in msgs if child is None or m.child_frame_id == child]
    if not rows:
        return np.zeros(0), np.zeros((0, 2)), np.zeros((0, 2, 2))
    t = np.array([r[0] for r in rows])
    x = np.array([r[1] for r in rows])[:, [0, 2]]
    P = np.array([r[2] for r in rows])[:, [0, 2]][:, :, [0, 2]]
    return t, x, P


def load(bag: Path) -> dict:
    """Everything the summary and the picture need, from a recorded maritime bag."""
    msgs = read_topics(bag, {SONAR_TRUTH, SONAR_ESTIMATE, SONAR_OBSERVER, SONAR_PING, SONAR_TARGET_STATUS,
                             IDSQ_ESTIMATE, IDSQ_LAYOUT, RADAR_TRUTH, RADAR_DECOY, FUSION_SCORES})
    d: dict = {'tracks': {}, 'truth': {}}
    for track_id, (_, topic, truth_topic, child) in TRACKERS.items():
        if topic == RADAR_DECOY:
            rows = [pose_cov_to_position(m) for m in msgs.get(topic, [])]
            d['tracks'][track_id] = (np.array([r[0] for r in rows]), np.array([r[1] for r in rows]).reshape(-1, 2),
                                     np.array([r[2] for r in rows]).reshape(-1, 2, 2))
        else:
            d['tracks'][track_id] = _states(msgs.get(topic, []))
        d['truth'][track_id] = _states(msgs.get(truth_topic, []), child)[:2]
    d['observer'] = _states(msgs.get(SONAR_OBSERVER, []))[1]
    d['pings'] = np.array([[m.point.x, m.point.y] for m in msgs.get(SONAR_PING, [])]).reshape(-1, 2)
    from track_msgs_py.records.sonar import SonarTargetStatus
    detections = 0
    for arr in msgs.get(SONAR_TARGET_STATUS, []):
        for st in arr.status:
            detections = SonarTargetStatus.from_status(st).detections
    d['detections'] = detections
    layout = msgs.get(IDSQ_LAYOUT, [])
    d['sensors'] = pointcloud2_to_table(layout[-1]) if layout else None
    d['origin'] = stamp_to_sec(layout[-1].header.stamp) if layout else 0.0  # the network's step origin
    scores: dict[tuple[str, str], list] = {}
    for arr in msgs.get(FUSION_SCORES, []):
        rec = FusionPairs.from_msg(arr)
        for pair, score, combined, _, associated in rec.rows():
            scores.setdefault(tuple(sorted(pair)), []).append((rec.t, score, combined, associated))
    d['scores'] = {pair: np.array(rows) for pair, rows in scores.items()}  # columns t, score, combined, assoc
    return d


def run_start(d: dict) -> float:
    """The run's time zero [s of the recorded clock]: the network's step origin (the layout's stamp; the
    truth stamped k·T is step k − 1) when a layout was recorded, else the earliest truth or track stamp."""
    if d.get('sensors') is not None and 'origin' in d:
        return float(d['origin'])
    first = [float(v[0][0]) for group in ('truth', 'tracks') for v in d.get(group, {}).values() if len(v[0])]
    return min(first) if first else 0.0


def start_when(start: float) -> str:
    """The run's start: a UTC date for an epoch stamp, else the raw clock value."""
    return (f"{datetime.fromtimestamp(start, UTC):%Y-%m-%d %H:%M:%S} UTC" if start >= EPOCH_MIN
            else f'clock t={start:g} s')


def start_note(start: float) -> str:
    """The one line that names the run's start, printed before times relative to it."""
    return f"times in s from the run's start ({start_when(start)})"


def tracker_errors(d: dict) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Per track id: (stamps, position error [m]) at the stamps matched to its target's truth."""
    out = {}
    for track_id, (t, x, _) in d['tracks'].items():
        tt, xt = d['truth'][track_id]
        it, ie = match_stamps(tt, t) if t.size and tt.size else (np.zeros(0, int), np.zeros(0, int))
        out[track_id] = (t[ie], np.hypot(*(x[ie] - xt[it]).T) if ie.size else np.zeros(0))
    return out


def converged_at(t: np.ndarray, err: np.ndarray, limit: float = CONVERGED_M) -> float:
    """First stamp with a position error below ``limit`` (inf if never)."""
    ok = np.flatnonzero(err < limit)
    return float(t[ok[0]]) if ok.size else float('inf')


def verdicts(d: dict, errors: dict | None = None) -> dict[tuple[str, str], dict]:
    """Per pair: mean score, fraction associated after both trackers converged, verdict, instants."""
    errors = tracker_errors(d) if errors is None else errors
    conv = {k: converged_at(*e) for k, e in errors.items()}
    out = {}
    for pair, rows in d['scores'].items():
        t0 = max(conv.get(pair[0], float('inf')), conv.get(pair[1], float('inf')))
        after = rows[rows[:, 0] >= t0] if np.isfinite(t0) else rows[:0]
        frac = float(after[:, 3].mean()) if after.size else float('nan')
        out[pair] = {'mean_score': float(rows[:, 1].mean()), 'instants': len(rows), 'from': t0,
                     'instants_after': len(after), 'fraction': frac, 'ever': bool(rows[:, 3].any()),
                     'associated': bool(after.size and frac >= 0.5)}
    return out


# --- summary --------------------------------------------------------------------------------------

def maritime_metrics(bag: Path) -> list[str]:
    return summary_lines(load(bag), bag / PICTURE)


def summary_lines(d: dict, picture_path: Path) -> list[str]:
    """The summary of loaded data ``d`` (``load``); writes the picture to ``picture_path``."""
    errors = tracker_errors(d)
    start = run_start(d)
    n_pings = len(d['pings'])
    lines = [start_note(start),
             f'{"tracker":<16} {"target":<13} {"estimates":>9} {"RTAMS":>9} {"converged":>10} {"pings":>6} '
             f'{"detected":>8}']
    for track_id, (label, _, _, child) in TRACKERS.items():
        t, err = errors[track_id]
        sonar = track_id == SONAR_TRACK
        conv = converged_at(t, err) if t.size else float('inf')
        lines.append(f'{label:<16} {child.replace("t0", "decoy"):<13} {t.size:>9} '
                     f'{(f"{rms(err[:, None]):.1f} m" if t.size else "-"):>9} '
                     f'{(f"t={conv - start:.1f} s" if np.isfinite(conv) else "never"):>10} '
                     f'{(str(n_pings) if sonar else "-"):>6} {(str(d["detections"]) if sonar else "-"):>8}')
    v = verdicts(d, errors)
    lines.extend(true_pair_lines(v))
    if not v:
        lines.append('fusion: no scores recorded')
    else:
        lines.append(f'{"pair":<34} {"mean score":>10} {"assoc. after conv.":>18} {"verdict":>14} {"truth":>6}')
        for (a, b), r in sorted(v.items()):
            same = TRACKERS.get(a, ('',) * 4)[3] == TRACKERS.get(b, ('',) * 4)[3]
            name = f'{TRACKERS.get(a, (a,))[0]} | {TRACKERS.get(b, (b,))[0]}'
            frac = '-' if np.isnan(r['fraction']) else f'{100 * r["fraction"]:.0f}%'
            lines.append(f'{name:<34} {r["mean_score"]:>10.3f} {frac:>18} '
                         f'{"associated" if r["associated"] else "not assoc.":>14} {"same" if same else "diff":>6}')
    try:
        path = picture(d, picture_path, errors, v)
        lines.append(f'picture: {path.resolve()}')
    except Exception as exc:  # the summary must still print; the reason is one line
        lines.append(f'picture: not written ({type(exc).__name__}: {exc})')
    return lines


def true_pair_lines(v: dict) -> list[str]:
    """The goal: the sonar|network pair associated at ≥ 95 % of the instants after both converged,
    and the decoy's pairs never."""
    pair = tuple(sorted((SONAR_TRACK, NETWORK_TRACK)))
    if pair not in v or np.isnan(v[pair]['fraction']):
        return ['true pair (sonar | network): no scored instant after both converged']
    r = v[pair]
    n = r['instants_after']
    decoy = [p for p in v if RADAR_DECOY in p and v[p]['ever']]
    return [f'true pair (sonar | network) associated at {100 * r["fraction"]:.1f}% of {n} instants after both '
            f'converged (goal >= 95%); decoy pairs associated at any instant: {len(decoy)}']


# --- picture --------------------------------------------------------------------------------------

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
