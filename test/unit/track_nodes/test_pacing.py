"""The /clock pacing shared by the launcher and the clock node: epochs, steps, stamps and the hold for a
periodic topic that is a step behind."""

from __future__ import annotations

import pytest
from nav_msgs.msg import Odometry
from rclpy.serialization import serialize_message

from track_msgs_py.stamps import ns_to_stamp
from track_nodes.base.epoch import EpochError, parse_epoch
from track_nodes.launch.pacing import Cadence, clock_step, header_stamp_ns, node_time
from track_nodes.launch.tuning import HOLD_MAX, MAX_CLOCK_STEP

S = 1_000_000_000


def test_epochs():
    assert parse_epoch('now') is None
    assert parse_epoch('2026-01-01T00:00:00') == 1767225600 == parse_epoch('1767225600')
    for bad in ('0', '1.5', 'yesterday', str(2**31)):
        with pytest.raises(EpochError, match='epoch'):
            parse_epoch(bad, 'epoch')


def test_steps_are_bounded_and_never_pass_the_duration():
    assert clock_step(20.0) == pytest.approx((0.05, 0.0025))
    assert clock_step(1000.0)[0] == MAX_CLOCK_STEP  # bounded bursts: more steps, not longer ones
    assert node_time(7, 0.05, 0.3) == 0.3 and node_time(3, 0.05, None) == pytest.approx(0.15)


def test_header_stamp_of_a_serialized_message():
    msg = Odometry()
    msg.header.stamp = ns_to_stamp(1767225600 * S + 123_456_789)
    assert header_stamp_ns(serialize_message(msg)) == 1767225600 * S + 123_456_789
    assert header_stamp_ns(b'\x00\x01') is None


def test_a_periodic_topic_behind_holds_the_clock_two_periods_ahead_at_most():
    c = Cadence()
    for k in range(3):
        c.seen('/idsq/estimate', (k + 1) * S)  # stamps 1, 2, 3 s: period 1 s
    assert c.period('/idsq/estimate') == S
    assert c.holding(4 * S, 0.0) is None  # its stamp 4 is due at node time 4: not behind yet
    assert c.holding(6 * S - 1, 0.0) is None  # a topic derived from the next period's inputs trails by one
    assert c.holding(6 * S, 0.0) == '/idsq/estimate'  # passing 6 s before it delivered 4 s: held
    c.seen('/idsq/estimate', 4 * S)
    assert c.holding(6 * S, 0.1) is None


def test_irregular_and_stopped_topics_hold_nothing_for_long():
    c = Cadence()
    for t in (1.0, 2.5, 7.0):  # pings: no period
        c.seen('/sonar/ping', round(t * S))
    assert c.period('/sonar/ping') is None and c.holding(100 * S, 0.0) is None
    for k in range(3):
        c.seen('/demo/truth', k * S // 10)
    assert c.holding(10 * S, 0.0) == '/demo/truth'  # stopped (or very late): held ...
    assert c.holding(10 * S, HOLD_MAX - 0.1) == '/demo/truth'
    assert c.holding(10 * S, HOLD_MAX + 0.1) is None  # ... for HOLD_MAX wall seconds, then no more
    assert c.holding(20 * S, HOLD_MAX + 1.0) is None
