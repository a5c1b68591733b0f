"""One-screen summary of a recorded bag, printed by the launcher after a recorded run.

Generic part: path, duration, messages per topic. Scenario part (``summary:`` in the
scenario's ``track_launch`` entry): metrics against truth, computed by track_core.metrics.
"""

from __future__ import annotations

import re
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


def rfid_metrics(bag: Path) -> list[str]:
    """RFID scenario: found or not, steps, turns, distance walked and the final distance to the tag.

    From the reader's truth status (``/rfid/user/status``, the last one: steps = MOVEs walked with
    repeated ones, turns = rotations made including the initial search for the signal and detours),
    the ``/rfid/found`` event and the commands (``/rfid/command``, counted once per seq: re-sent
    copies are not new commands).
    """
    from track_msgs_py.topics import RFID_COMMAND, RFID_FOUND, RFID_USER_STATUS

    msgs = read_topics(bag, {RFID_COMMAND, RFID_FOUND, RFID_USER_STATUS})
    status = [{kv.key: kv.value for kv in m.status[0].values} for m in msgs.get(RFID_USER_STATUS, []) if m.status]
    if not status:
        return ['rfid: no user status recorded']
    last = status[-1]
    commands: dict[int, dict] = {}
    for m in msgs.get(RFID_COMMAND, []):
        for st in m.status:
            v = {kv.key: kv.value for kv in st.values}
            commands.setdefault(int(v['seq']), v)
    kinds = [v['kind'] for _, v in sorted(commands.items())]
    done = [v for v in commands.values() if v['kind'] == 'done']
    found = bool(msgs.get(RFID_FOUND)) or last.get('found') == 'true'
    if found:
        verdict = 'tag FOUND'
    elif done:
        verdict = f'tag NOT found ({done[-1].get("reason", "")})'
    else:
        verdict = 'tag NOT found (the search was still running when the recording stopped)'
    repeats = sum(v.get('repeat') == 'true' for v in commands.values())
    return [
        f'rfid: {verdict}',
        f'  steps {last["steps"]}, turns {last["turns"]}, distance walked {float(last["distance_m"]):.2f} m, '
        f'final distance to the tag {float(last["distance_to_tag_m"]):.3f} m',
        f'  commands {len(commands)} (MOVE {kinds.count("move")}, TURN {kinds.count("turn")}), '
        f'repeated steps {repeats}, steps undone by the user {last["repeats"]}',
    ]


SCENARIO_METRICS = {'demo': demo_metrics, 'fusion': fusion_metrics}
SCENARIO_METRICS['sonar'] = sonar_metrics
SCENARIO_METRICS['rfid'] = rfid_metrics


# Scenarios whose many per-node topics are listed as one line: scenario → (regex, label).
FOLD_AT = 5  # topics that differ only in their numbers (per-sensor topics) list as one line from this many


def summarize(bag: Path, scenario: str | None = None) -> list[str]:
    lines = [f'bag: {bag.resolve()}']
    with Reader(bag) as reader:
        lines.append(f'duration {reader.duration * 1e-9:.1f} s, {reader.message_count} messages')
        families: dict[str, list] = {}
        for conn in reader.connections:
            families.setdefault(re.sub(r'\d+', '*', conn.topic), []).append(conn)
        for key in sorted(families):
            conns = families[key]
            if len(conns) >= FOLD_AT:
                lines.append(f'  {key:<28} {f"({len(conns)} topics)":<44} {sum(c.msgcount for c in conns):>7}')
                continue
            for conn in sorted(conns, key=lambda c: c.topic):
                lines.append(f'  {conn.topic:<28} {conn.msgtype:<44} {conn.msgcount:>7}')
    if scenario in SCENARIO_METRICS:
        lines += SCENARIO_METRICS[scenario](bag)
    return lines


def print_summary(bag: Path, scenario: str | None = None) -> None:
    print('\n'.join(summarize(bag, scenario)), flush=True)


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
    from track_msgs_py.convert import odometry_to_pose, stamp_to_sec
    from track_msgs_py.topics import SLAM_EVENTS, SLAM_GPS, SLAM_MODE, SLAM_POSE, SLAM_TRUTH

    msgs = read_topics(bag, {SLAM_POSE, SLAM_TRUTH, SLAM_GPS, SLAM_EVENTS, SLAM_MODE})
    est = [odometry_to_pose(m) for m in msgs.get(SLAM_POSE, [])]
    if not est:
        return ['slam: no poses recorded']
    t_est = np.array([e[0] for e in est])
    x_est = np.array([e[1] for e in est])
    lines = [f'slam: {len(est)} poses, t = {t_est[0]:.1f} .. {t_est[-1]:.1f} s']
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
    kinds = [{kv.key: kv.value for kv in st.values} for a in msgs.get(SLAM_EVENTS, []) for st in a.status]
    n_pf = sum(k.get('event') == 'to_pf' for k in kinds)
    back = [int(k.get('pf_scans', 0)) for k in kinds if k.get('event') in ('to_cekf', 'pf_timeout')]
    timeouts = sum(k.get('event') == 'pf_timeout' for k in kinds)
    line = f'  PF switches {n_pf}'
    if back:
        line += f', back to CEKF {len(back)} ({timeouts} by timeout), median {np.median(back):g} PF scans'
    modes = [{kv.key: kv.value for kv in st.values} for a in msgs.get(SLAM_MODE, []) for st in a.status]
    if modes:
        last = modes[-1]
        line += (f'; landmarks {last.get("landmarks")}, scans {last.get("scans")}, final mode {last.get("mode")}; '
                 f'dropped observations {last.get("dropped_observations")}, refused messages '
                 f'{last.get("refused_messages")}')
    lines.append(line)
    return lines


SCENARIO_METRICS['slam'] = slam_metrics


def idsq_metrics(bag: Path) -> list[str]:
    """IDSQ scenario: estimate error against the truth (matched by stamp), leaders used, handoff bytes.

    Bytes per step = all handoff payloads sent (re-sends after a timeout or a refusal included)
    divided by the number of estimates (leader steps); re-selections come from ``/idsq/leader``.
    """
    import re
    from itertools import pairwise

    from track_msgs_py.topics import IDSQ_ESTIMATE, IDSQ_HANDOFF_REGEX, IDSQ_LEADER, IDSQ_TRUTH

    with Reader(bag) as reader:
        handoff_topics = {c.topic for c in reader.connections if re.match(IDSQ_HANDOFF_REGEX, c.topic)}
    msgs = read_topics(bag, {IDSQ_TRUTH, IDSQ_ESTIMATE, IDSQ_LEADER} | handoff_topics)
    truth = [odometry_to_cv_state(m) for m in msgs.get(IDSQ_TRUTH, [])]
    est = [odometry_to_cv_state(m) for m in msgs.get(IDSQ_ESTIMATE, [])]
    if not truth or not est:
        return ['idsq: no truth/estimate pairs recorded']
    it, ie = match_stamps(np.array([s[0] for s in truth]), np.array([s[0] for s in est]))
    err = np.array([s[1] for s in truth])[it][:, [0, 2]] - np.array([s[1] for s in est])[ie][:, [0, 2]]
    dist = np.hypot(err[:, 0], err[:, 1])
    events = [{kv.key: kv.value for kv in st.values} for arr in msgs.get(IDSQ_LEADER, []) for st in arr.status]
    leaders = [int(e['leader']) for e in events if e.get('event') == 'step']
    reselect = sum(e.get('event') == 'reselect' for e in events)
    sent = sum(len(m.data) for t in handoff_topics for m in msgs.get(t, []))
    n_msgs = sum(len(msgs.get(t, [])) for t in handoff_topics)
    return [
        f'idsq: {len(ie)} estimates matched to truth',
        f'  RMSE {rms(err):.2f} m, mean error {dist.mean():.2f} m, max {dist.max():.2f} m, final {dist[-1]:.2f} m',
        f'  leaders used {len(set(leaders))} distinct over {len(leaders)} steps '
        f'({sum(a != b for a, b in pairwise(leaders))} changes), '
        f're-selections {reselect}',
        f'  handoffs {n_msgs}, {sent} bytes, {sent / max(len(est), 1):.1f} bytes per step',
    ]


SCENARIO_METRICS['idsq'] = idsq_metrics


def ais_metrics(bag: Path) -> list[str]:
    """AIS scenario: the recorded same-ship verdicts against the MMSI, for the fusion's method.

    Truth: the ``/ais/<source>/truth`` tables (local track → MMSI, evaluation only). Verdicts:
    every pair of ``/fusion/scores``; a pair is declared the same ship when it was associated at
    at least half of its scored instants (as ``track-experiment ais-association``), then made
    one-to-one (Hungarian on the pair's mean score, ``track_core.ais.match_one_to_one``). Precision =
    right / declared, recall = right / same-ship pairs that were scored at least once.
    """
    from track_core.ais import Metrics, match_one_to_one

    with Reader(bag) as reader:
        truth_topics = {c.topic for c in reader.connections
                        if c.topic.startswith('/ais/') and c.topic.endswith('/truth')}
    msgs = read_topics(bag, {*truth_topics, FUSION_SCORES})
    mmsi: dict[str, int] = {}
    ships_by_source: dict[str, set[int]] = defaultdict(set)
    for topic in truth_topics:
        for arr in msgs.get(topic, [])[-1:]:
            for st in arr.status:
                v = {kv.key: kv.value for kv in st.values}
                mmsi[st.name] = int(v['mmsi'])
                ships_by_source[topic].add(int(v['mmsi']))
    pairs: dict[tuple[str, str], list] = {}
    methods, evaluations = set(), 0
    for arr in msgs.get(FUSION_SCORES, []):
        for st in arr.status:
            a, _, b = st.name.partition(' | ')
            v = {kv.key: kv.value for kv in st.values}
            rec = pairs.setdefault(tuple(sorted((a, b))), [0.0, 0, 0])  # fusion orders a pair by first report
            rec[0] += float(v['score'])
            rec[1] += v['associated'] == 'true'
            rec[2] += 1
            methods.add(v.get('method', '?'))
            evaluations += 1
    if not mmsi or not pairs:
        return [f'ais: {"no truth tables" if not mmsi else "no fusion scores"} recorded']
    keys = [p for p in pairs if p[0] in mmsi and p[1] in mmsi]
    if not keys:
        return ['ais: no scored pair has a truth entry (were /ais/*/truth recorded?)']
    same = np.array([mmsi[a] == mmsi[b] for a, b in keys])
    mean = np.array([pairs[p][0] / pairs[p][2] for p in keys])
    declared = np.array([pairs[p][1] >= 0.5 * pairs[p][2] for p in keys])
    ids = {name: k for k, name in enumerate(sorted({x for p in keys for x in p}))}
    pa = np.array([ids[a] for a, _ in keys])
    pb = np.array([ids[b] for _, b in keys])
    source_pair = np.array([f'{a.rsplit("/", 1)[0]} | {b.rsplit("/", 1)[0]}' for a, b in keys])
    matched = np.zeros_like(declared)
    for sp in np.unique(source_pair):  # one assignment per pair of sources
        sel = np.flatnonzero((source_pair == sp) & declared)
        if sel.size:
            matched[sel] = match_one_to_one(pa[sel], pb[sel], mean[sel], np.ones(sel.size, bool))
    sources = sorted(ships_by_source)
    both = set.intersection(*ships_by_source.values()) if len(sources) >= 2 else set()
    undecidable = len(both) - int(same.sum())

    def metrics(d: np.ndarray) -> Metrics:
        return Metrics(int(np.sum(d & same)), int(np.sum(d & ~same)), int(np.sum(~d & same)), undecidable)

    lines = [f'ais: method {"/".join(sorted(methods))}; '
             + ', '.join(f'{t.split("/")[2]} {len(ships_by_source[t])} tracks' for t in sources)
             + f'; {len(both)} ships seen by both; {evaluations} pair evaluations, {len(keys)} track pairs, '
             f'{int(same.sum())} of them the same ship']
    for label, d in (('threshold (associated at ≥ half of its instants)', declared), ('one-to-one', matched)):
        m = metrics(d)
        lines.append(f'  {label:<50} precision {m.precision:.3f}  recall {m.recall:.3f}  F1 {m.f1:.3f}  '
                     f'(TP {m.tp}, FP {m.fp}, FN {m.fn})')
    wrong = [k for k in np.flatnonzero(matched & ~same)][:5]
    missed = [k for k in np.flatnonzero(~matched & same)][:5]
    for k in wrong:
        lines.append(f'  wrong:  {keys[k][0]} | {keys[k][1]} (mean score {mean[k]:.2f}, MMSI {mmsi[keys[k][0]]} vs '
                     f'{mmsi[keys[k][1]]})')
    for k in missed:
        lines.append(f'  missed: {keys[k][0]} | {keys[k][1]} (mean score {mean[k]:.2f}, associated '
                     f'{pairs[keys[k]][1]}/{pairs[keys[k]][2]} instants)')
    return lines


SCENARIO_METRICS['ais'] = ais_metrics


def maritime_metrics(bag: Path) -> list[str]:
    """Maritime scenario (issue 8): see ``track_nodes.maritime.maritime_metrics`` (also writes picture.png)."""
    from track_nodes.maritime import maritime_metrics as metrics

    return metrics(bag)


SCENARIO_METRICS['maritime'] = maritime_metrics
