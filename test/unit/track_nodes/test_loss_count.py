"""LossCounter: sequence gaps on single-publisher topics, middleware events on shared ones."""

from track_nodes.bag.loss_count import LossCounter


def test_gaps_of_one_publisher_are_counted_exactly():
    c = LossCounter()
    c.publishers('/a', 1)
    assert [c.received('/a', s) for s in (1, 2, 5, 6, 10)] == [0, 0, 2, 0, 3]
    assert c.lost['/a'] == 5 and c.total() == 5
    assert c.event('/a', 4) == 0  # the gaps already count these; no double count


def test_restart_and_first_message_count_nothing():
    c = LossCounter()
    c.publishers('/a', 1)
    assert c.received('/a', 40) == 0  # joined late: nothing known before
    assert c.received('/a', 1) == 0  # the publisher restarted
    assert c.received('/a', 3) == 1


def test_several_publishers_use_events_not_gaps():
    c = LossCounter()
    c.publishers('/b', 2)
    assert [c.received('/b', s) for s in (1, 1, 2, 7)] == [0, 0, 0, 0]
    assert c.event('/b', 3) == 3 and c.event('/b', 0) == 0
    c.publishers('/b', 1)  # back to one: gaps count again, from the next message on
    assert c.received('/b', 9) == 0 and c.received('/b', 11) == 1
    assert c.lost['/b'] == 4
