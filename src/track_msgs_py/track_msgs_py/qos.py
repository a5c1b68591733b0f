"""QoS profiles of the package set, and the profile for a topic from ``topics.TOPICS``.

Why these profiles (docs/DESIGN.md): sensor-like streams are best effort (a late report is worth
less than the next one), estimates are reliable (a dropped estimate breaks a trajectory),
static data (sensor layout, map) is transient-local so a late joiner still gets it.

Compatibility: a best-effort subscription accepts a reliable or best-effort publisher; a
reliable subscription does NOT match a best-effort publisher. A volatile subscription matches
a transient-local publisher (and then gets no history). The recorder should subscribe with
``qos_for_topic`` so it matches what the publisher offers.

The profiles are shared module-level objects: do not mutate them; ``qos_for_topic`` returns
a copy.
"""

from __future__ import annotations

import copy

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from track_msgs_py.tf import TF_QOS, TF_STATIC_QOS
from track_msgs_py.topics import TOPICS

SENSOR_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=5,
                        reliability=ReliabilityPolicy.BEST_EFFORT, durability=DurabilityPolicy.VOLATILE)
# A subscriber's queue on a sensor stream: deep enough that a process descheduled for a second of a
# loaded machine at 100 messages/s loses nothing (the publisher keeps depth 5; both are best effort).
SENSOR_SUB_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=100,
                            reliability=ReliabilityPolicy.BEST_EFFORT, durability=DurabilityPolicy.VOLATILE)
ESTIMATE_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=10,
                          reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE)
STATIC_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1,
                        reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
# rclpy's TimeSource (use_sim_time) subscribes to /clock with
# QoSProfile(depth=1, reliability=BEST_EFFORT) (volatile), like rclcpp::ClockQoS. Publishing
# with the same profile matches it; only the newest time matters, so depth 1.
CLOCK_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1,
                       reliability=ReliabilityPolicy.BEST_EFFORT, durability=DurabilityPolicy.VOLATILE)
# IDSQ handoffs and acks: reliable, and transient-local so a handoff published just before the
# receiver matched is still delivered (depth 4: a leader can hand off again before the ack).
# Across an unplugged host KEEP_LAST 4 is kept by measurement (tools/unplug_host.py,
# README "Scenarios and time"): after a partition heals, what must arrive is the late ack of a
# handoff that timed out, and the revoke it draws (the chain rule, track_core.idsq.leader_protocol); a
# late handoff that is lost instead is harmless (its sender re-selected). Each writer of these
# topics has one reader, and publishes at most one message per step to it, fewer to a receiver
# that timed out (tried last); with depth 4 every 5 s and 25 s unplug converged back to one chain,
# as with KEEP_ALL, which gave no better figure but a history that grows for as long as a reader
# is gone (and, reliable, blocks the publisher once the resource limits are reached).
HANDOFF_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=4, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
# Step-keyed truth that late joiners must still receive in full (a sensor that matched after
# step 0 would otherwise never start): reliable, transient-local, deep history.
TRUTH_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=256, reliability=ReliabilityPolicy.RELIABLE,
                       durability=DurabilityPolicy.TRANSIENT_LOCAL)

# IDSQ readings (one per sensor and step, records.idsq.IdsqReading): reliable (a lost reading makes a
# leader step predict-only) and deep (a busy leader loses none). The sensors subscribe volatile by
# default, so any reliable publisher (a driver's default QoS) matches; the simulator publishes
# transient-local, and the scenario files subscribe transient-local (``reading_durability``), so a
# sensor that matched late still gets step 0 (the election needs it).
READING_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=256, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.VOLATILE)
READING_LATCHED_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=256, reliability=ReliabilityPolicy.RELIABLE,
                                 durability=DurabilityPolicy.TRANSIENT_LOCAL)
# The start election (/idsq/election): one sample per sensor, every one kept for a late reader (a
# keyless topic: the reader's KEEP_LAST depth counts the samples of all K writers together).
ELECTION_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=4096, reliability=ReliabilityPolicy.RELIABLE,
                          durability=DurabilityPolicy.TRANSIENT_LOCAL)

QOS_BY_KIND: dict[str, QoSProfile] = {
    'sensor': SENSOR_QOS,
    'estimate': ESTIMATE_QOS,
    'static': STATIC_QOS,
    'clock': CLOCK_QOS,
    'tf': TF_QOS,
    'tf_static': TF_STATIC_QOS,
}


def qos_for_topic(topic: str) -> QoSProfile:
    """A copy of the profile of ``topic``'s QoS kind in ``TOPICS``; ``ESTIMATE_QOS`` for unknown topics."""
    spec = TOPICS.get(topic)
    return copy.copy(QOS_BY_KIND[spec.qos] if spec is not None else ESTIMATE_QOS)
