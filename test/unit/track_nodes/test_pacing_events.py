"""The clock of a multi-process run is held only by topics with a cadence: an event-driven topic (an IDSQ
sensor's handoff inbox: a few handoffs one period apart while the leader is near, then none) stalls it at
most once per run, however often it shows a period again (a long run stalled ``HOLD_MAX`` at every lead)."""

from __future__ import annotations

from track_nodes.launch.pacing import Cadence
from track_nodes.launch.tuning import HOLD_MAX

S = 1_000_000_000
INBOX = '/idsq/sensor_27/handoff'


def test_a_topic_that_stopped_once_never_holds_the_clock_again():
    c = Cadence()
    for k in (3, 4, 5):  # three handoffs one step apart, then the leader moves on
        c.seen(INBOX, k * S)
    assert c.holding(8 * S, 0.0) == INBOX
    assert c.holding(8 * S, HOLD_MAX + 0.1) is None  # one stall of HOLD_MAX ...
    for k in (40, 41, 42):  # ... the leader comes back for three steps and leaves again
        c.seen(INBOX, k * S)
    assert c.holding(50 * S, HOLD_MAX + 1.0) is None  # ... and no second one
    assert INBOX in c.events


def test_a_topic_with_an_irregular_gap_never_holds_it():
    c = Cadence()
    for k in (3, 4, 9, 10, 11):  # gaps 1, 5, 1, 1: a period again at the end
        c.seen(INBOX, k * S)
    assert c.period(INBOX) is None and c.holding(20 * S, 0.0) is None


def test_a_topic_with_a_cadence_still_holds_it_every_time_it_is_behind():
    c = Cadence()
    for k in range(1, 4):
        c.seen('/idsq/estimate', k * S)
    assert c.holding(6 * S, 0.0) == '/idsq/estimate'
    for k in range(4, 40):  # it catches up, at its period, for a long time
        c.seen('/idsq/estimate', k * S)
        assert c.holding((k + 2) * S, 1.0) is None
    assert c.holding(42 * S, 2.0) == '/idsq/estimate' and '/idsq/estimate' not in c.events
