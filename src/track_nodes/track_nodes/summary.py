"""One-screen summary of a recorded bag, printed by the launcher after a recorded run.

Generic part: path, duration, messages per topic. Scenario part (``summary:`` in the
scenario's ``track_launch`` entry): metrics against truth, computed by track_core.metrics.
"""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path

import numpy as np
from rclpy.serialization import deserialize_message
from rosbags.rosbag2 import Reader

from track_core.metrics import match_stamps, mean_nees, rms
from track_msgs_py.convert import odometry_to_cv_state
from track_msgs_py.topics import DEMO_TRACK, DEMO_TRUTH, FUSION_SCORES
from track_nodes.bag_io import msg_class


def read_topics(bag: Path, topics: set[str] | None = None) -> dict[str, list]:
    """Deserialised messages per topic, in bag order."""
    out: dict[str, list] = defaultdict(list)
    with Reader(bag) as reader:
        conns = [c for c in reader.connections if topics is None or c.topic in topics]
        for conn, _, raw in reader.messages(connections=conns):
            out[conn.topic].append(deserialize_message(raw, msg_class(conn.msgtype)))
    return out


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
    return [
        f'demo tracker: {len(ie)} estimates matched to truth',
        f'  position RMSE {rms(err[:, [0, 2]]):.3f} m, velocity RMSE {rms(err[:, [1, 3]]):.3f} m/s',
        f'  mean NEES {mean_nees(err[settled], P_est[settled]):.2f} (4 states; ≈4 when consistent, '
        'pos–vel cross-covariance not carried by Odometry)',
    ]


def pair_verdicts(bag: Path, topic: str = FUSION_SCORES) -> dict[tuple[str, str], dict]:
    """Per pair from the fusion scores: mean instant score, fraction associated, last verdict."""
    stats: dict[tuple[str, str], dict] = {}
    for arr in read_topics(bag, {topic}).get(topic, []):
        for st in arr.status:
            a, _, b = st.name.partition(' | ')
            v = {kv.key: kv.value for kv in st.values}
            rec = stats.setdefault((a, b), {'scores': [], 'associated': []})
            rec['scores'].append(float(v['score']))
            rec['associated'].append(v['associated'] == 'true')
    return {pair: {'mean_score': float(np.mean(r['scores'])), 'fraction_associated': float(np.mean(r['associated'])),
                   'final': r['associated'][-1], 'instants': len(r['scores'])} for pair, r in stats.items()}


def same_simulated_ship(a: str, b: str) -> bool:
    """report_source tracks ``<prefix>/t<i>`` of sources sharing one truth are the same ship iff i matches."""
    return a.rsplit('/', 1)[-1] == b.rsplit('/', 1)[-1]


def fusion_metrics(bag: Path) -> list[str]:
    verdicts = pair_verdicts(bag)
    if not verdicts:
        return ['fusion: no scores recorded']
    lines = [f'{"pair":<26} {"mean score":>10} {"assoc. time":>11} {"final":>6} {"truth":>6}']
    for (a, b), v in sorted(verdicts.items()):
        lines.append(f'{a + " | " + b:<26} {v["mean_score"]:>10.3f} {100 * v["fraction_associated"]:>10.0f}% '
                     f'{"yes" if v["final"] else "no":>6} {"same" if same_simulated_ship(a, b) else "diff":>6}')
    return lines


def sonar_metrics(bag: Path) -> list[str]:
    """Sonar scenario: RTAMS of the estimate against the truth, pings emitted and detected by the target.

    RTAMS with l = 0 (the paper's Section 5, one run): √(mean over matched stamps of the squared
    position error). Pings emitted: ``/sonar/ping`` events; detected: the target's last
    ``/sonar/target/status`` ``detections`` (a ping is heard one step after it is emitted).
    """
    from track_msgs_py.topics import SONAR_ESTIMATE, SONAR_PING, SONAR_TARGET_STATUS, SONAR_TRUTH

    msgs = read_topics(bag, {SONAR_TRUTH, SONAR_ESTIMATE, SONAR_PING, SONAR_TARGET_STATUS})
    truth = [odometry_to_cv_state(m) for m in msgs.get(SONAR_TRUTH, [])]
    est = [odometry_to_cv_state(m) for m in msgs.get(SONAR_ESTIMATE, [])]
    pings = len(msgs.get(SONAR_PING, []))
    detections, modes = 0, []
    for arr in msgs.get(SONAR_TARGET_STATUS, []):
        for st in arr.status:
            v = {kv.key: kv.value for kv in st.values}
            detections = int(v.get('detections', detections))
            modes.append(v.get('mode', ''))
    if not truth or not est:
        return ['sonar: no truth/estimate pairs recorded']
    it, ie = match_stamps(np.array([s[0] for s in truth]), np.array([s[0] for s in est]))
    err = np.array([s[1] for s in truth])[it] - np.array([s[1] for s in est])[ie]
    evading = sum(m == 'evade' for m in modes)
    return [
        f'sonar: {len(ie)} estimates matched to truth',
        f'  RTAMS {rms(err[:, [0, 2]]):.2f} m, final position error {float(np.hypot(*err[-1, [0, 2]])):.2f} m',
        f'  pings emitted {pings}/{len(ie)} steps, pings detected by the target {detections}, '
        f'target evading {evading}/{len(modes)} steps',
    ]


SCENARIO_METRICS = {'demo': demo_metrics, 'fusion': fusion_metrics}
SCENARIO_METRICS['sonar'] = sonar_metrics


def summarize(bag: Path, scenario: str | None = None) -> list[str]:
    lines = [f'bag: {bag.resolve()}']
    with Reader(bag) as reader:
        lines.append(f'duration {reader.duration * 1e-9:.1f} s, {reader.message_count} messages')
        for conn in sorted(reader.connections, key=lambda c: c.topic):
            lines.append(f'  {conn.topic:<28} {conn.msgtype:<44} {conn.msgcount:>7}')
    if scenario in SCENARIO_METRICS:
        lines += SCENARIO_METRICS[scenario](bag)
    return lines


def print_summary(bag: Path, scenario: str | None = None) -> None:
    print('\n'.join(summarize(bag, scenario)), flush=True)
