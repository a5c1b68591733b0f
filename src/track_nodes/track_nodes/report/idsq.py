"""Summary of the IDSQ scenario: error against the truth, leaders, handoff bytes."""

from __future__ import annotations

import re
from itertools import pairwise
from pathlib import Path

import numpy as np

from track_core.idsq.leader_protocol import step_of_stamp
from track_core.metrics import match_stamps, rms
from track_msgs_py.covariance import xy_block
from track_msgs_py.odometry import odometry_to_cv_state
from track_msgs_py.records.idsq import IdsqHandoff, IdsqLeaderEvent
from track_msgs_py.stamps import stamp_to_sec
from track_msgs_py.topics import IDSQ_ESTIMATE, IDSQ_HANDOFF_REGEX, IDSQ_LAYOUT, IDSQ_LEADER, IDSQ_TRUTH
from track_nodes.report.read import read_topics, topics_matching


def recorded_track(bag: Path, dt: float) -> tuple[list[int | None], np.ndarray, np.ndarray]:
    """The bag's ``/idsq/estimate`` in bag order: (step of each, means (T, 2), x/y covariances (T, 2, 2)).

    Steps count from the step origin, the stamp of the last (stamped) ``/idsq/layout``; a bag with no
    stamped layout raises ValueError.
    """
    msgs = read_topics(bag, {IDSQ_ESTIMATE, IDSQ_LAYOUT})
    stamps = [stamp_to_sec(m.header.stamp) for m in msgs.get(IDSQ_LAYOUT, [])]
    if not stamps or not stamps[-1]:
        raise ValueError(f'{bag}: no stamped {IDSQ_LAYOUT}: the step origin is unknown')
    est = msgs.get(IDSQ_ESTIMATE, [])
    steps = [step_of_stamp(stamp_to_sec(m.header.stamp), dt, stamps[-1]) for m in est]
    means = np.array([odometry_to_cv_state(m)[1][[0, 2]] for m in est]).reshape(-1, 2)
    covs = np.array([xy_block(m.pose.covariance) for m in est]).reshape(-1, 2, 2)
    return steps, means, covs


def idsq_metrics(bag: Path) -> list[str]:
    """IDSQ scenario: estimate error against the truth (matched by stamp), leaders used, handoff bytes.

    Bytes per step = the package size (``IdsqHandoff.package_bytes``) of all handoffs sent (re-sends after
    a timeout or a refusal included) divided by the number of estimates (leader steps); re-selections
    come from ``/idsq/leader``.
    """
    handoff_topics = topics_matching(bag, lambda topic: re.match(IDSQ_HANDOFF_REGEX, topic))
    msgs = read_topics(bag, {IDSQ_TRUTH, IDSQ_ESTIMATE, IDSQ_LEADER} | handoff_topics)
    truth = [odometry_to_cv_state(m) for m in msgs.get(IDSQ_TRUTH, [])]
    est = [odometry_to_cv_state(m) for m in msgs.get(IDSQ_ESTIMATE, [])]
    if not truth or not est:
        return ['idsq: no truth/estimate pairs recorded']
    it, ie = match_stamps(np.array([s[0] for s in truth]), np.array([s[0] for s in est]))
    err = np.array([s[1] for s in truth])[it][:, [0, 2]] - np.array([s[1] for s in est])[ie][:, [0, 2]]
    dist = np.hypot(err[:, 0], err[:, 1])
    events = [IdsqLeaderEvent.from_msg(m) for m in msgs.get(IDSQ_LEADER, [])]
    leaders = [e.leader for e in events if e.event == 'step']
    reselect = sum(e.event == 'reselect' for e in events)
    sent = sum(IdsqHandoff.from_msg(m, frame_id=None).package_bytes for t in handoff_topics for m in msgs.get(t, []))
    n_msgs = sum(len(msgs.get(t, [])) for t in handoff_topics)
    return [
        f'idsq: {len(ie)} estimates matched to truth',
        f'  RMSE {rms(err):.2f} m, mean error {dist.mean():.2f} m, max {dist.max():.2f} m, final {dist[-1]:.2f} m',
        f'  leaders used {len(set(leaders))} distinct over {len(leaders)} steps '
        f'({sum(a != b for a, b in pairwise(leaders))} changes), '
        f're-selections {reselect}',
        f'  handoffs {n_msgs}, {sent} bytes, {sent / max(len(est), 1):.1f} bytes per step',
    ]
