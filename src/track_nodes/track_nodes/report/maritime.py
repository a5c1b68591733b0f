"""The ``maritime`` scenario: sonar, sensor network and fusion in one picture.

What runs (``config/maritime.yaml``, written by ``scenario_yaml`` below):
- ``smart_target`` crosses the IDSQ field south to north (7 m/s, evading at up to 12 m/s when it
  hears a ping; the network's v_max is 15 m/s); truth ``/sonar/target/truth``.
- ``sonar_observer`` (the AUV: SS-PF + eq. 7 scheduling) follows and pings it; ``/sonar/estimate``
  (child ``sonar_track``).
- ``vehicle_sim`` (``publish_truth: false``) feeds every sensor the loudest (nearest) of the smart
  target's and the decoy's truths; the ``acoustic_sensor``/``doa_sensor`` nodes track with IDSQ
  (``prediction: bank``, a grid reaching 300 m north, 60 m radio range); ``/idsq/estimate`` (child
  ``idsq_track``). Every node steps at Δt = T = 1 s: the truth stamped k·T is the network's step k −
  1.
- ``report_source`` ``radar`` sees only the decoy (a constant-velocity vessel east of the field);
  truth ``/radar/truth`` (child ``t0``), reports ``/radar/t0``.
- ``fusion`` scores the three pairs at k·1 s (``schedule: stamps``: a replay gives the same scores).

Evaluation (``maritime_summary.maritime_metrics``, ``SCENARIO_METRICS["maritime"]``, after a
recorded run): per tracker RTAMS (l = 0: √ mean squared position error over the matched stamps);
pings emitted and detected; per pair the mean instant score and the verdict: "associated" when
associated at ≥ half of its scored instants after both trackers converged (position error below
``CONVERGED_M``, evaluation only); the true pair's fraction (goal ≥ 95 %) and whether a decoy pair
was ever associated; ``picture.png`` in the bag (``maritime_picture.picture``). Times are seconds
from ``run_start`` (the network's step origin, else the earliest stamp); ``start_note`` gives the
UTC date. In full: docs/MODULES.md, "The maritime scenario in full".
"""

from __future__ import annotations

from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from track_core.metrics import match_stamps
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
    for msg in msgs.get(SONAR_TARGET_STATUS, []):
        detections = SonarTargetStatus.from_msg(msg).detections
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
