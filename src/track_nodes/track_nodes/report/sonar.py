"""Summary of the sonar scenario: RTAMS, pings emitted and detected."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from track_core.metrics import match_stamps, rms
from track_msgs_py.odometry import odometry_to_cv_state
from track_nodes.report.read import read_topics


def sonar_metrics(bag: Path) -> list[str]:
    """Sonar scenario: RTAMS of the estimate against the truth, pings emitted and detected by the target.

    RTAMS with l = 0 (the paper's Section 5, one run): √(mean over matched stamps of the squared
    position error). Pings emitted: ``/sonar/ping`` events; detected: the target's last
    ``/sonar/target/status`` ``detections`` (a ping is heard one step after it is emitted).
    """
    from track_msgs_py.records.sonar import SonarTargetStatus
    from track_msgs_py.topics import SONAR_ESTIMATE, SONAR_PING, SONAR_TARGET_STATUS, SONAR_TRUTH

    msgs = read_topics(bag, {SONAR_TRUTH, SONAR_ESTIMATE, SONAR_PING, SONAR_TARGET_STATUS})
    truth = [odometry_to_cv_state(m) for m in msgs.get(SONAR_TRUTH, [])]
    est = [odometry_to_cv_state(m) for m in msgs.get(SONAR_ESTIMATE, [])]
    pings = len(msgs.get(SONAR_PING, []))
    detections, modes = 0, []
    for msg in msgs.get(SONAR_TARGET_STATUS, []):
        rec = SonarTargetStatus.from_msg(msg)
        detections = rec.detections
        modes.append(rec.mode)
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
