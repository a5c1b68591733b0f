"""The readiness announcement (``/track/ready``) as a record, who of two twins is the newcomer, and the
launcher's ready deadline, which grows with the node count and says how it was derived."""

from __future__ import annotations

import pytest

from track_msgs_py.records import RecordError
from track_msgs_py.records.ready import NodeReady
from track_msgs_py.topics import READY, relative
from track_nodes.launch.graph import listing, ready_deadline
from track_nodes.launch.tuning import READY_PER_NODE, READY_PER_PROCESS, READY_TIMEOUT


def _rec(**kw) -> NodeReady:
    return NodeReady(**{'name': '/ns/sensor_3', 'pid': 4321, 'host': 'h1', 'start_ns': 10**18,
                        'executable': 'acoustic_sensor', **kw})


def test_the_announcement_round_trips_and_names_the_node():
    rec = _rec()
    msg = rec.to_msg()
    assert msg.name == '/ns/sensor_3' and msg.hardware_id == 'h1' and msg.message == 'ready'
    assert NodeReady.from_msg(msg) == rec
    assert relative(READY) == READY  # ROS-wide: a namespaced node announces on the same topic


def test_a_malformed_announcement_is_one_line():
    msg = _rec().to_msg()
    msg.name = '/other'
    with pytest.raises(RecordError, match='differs'):
        NodeReady.from_msg(msg)
    msg = _rec().to_msg()
    msg.values = [kv for kv in msg.values if kv.key != 'pid']
    with pytest.raises(RecordError, match="missing key 'pid'"):
        NodeReady.from_msg(msg)
    with pytest.raises(ValueError, match='fully qualified'):
        _rec(name='sensor_3')


def test_exactly_one_of_two_twins_is_the_newcomer():
    older = _rec()
    pairs = [(older, _rec(start_ns=older.start_ns + 1)),  # the later start
             (older, _rec(host='h2')),  # same start: the greater host name
             (older, _rec(pid=older.pid + 1))]  # same start and host: the greater pid
    for a, b in pairs:
        assert b.newer(a) and not a.newer(b)
        assert not a.same_node(b)
    assert older.same_node(_rec()) and not older.newer(_rec())


def test_the_ready_deadline_grows_with_the_node_count():
    small, why_small = ready_deadline(3, processes=True)
    big, why_big = ready_deadline(101, processes=True)
    assert small == READY_TIMEOUT + 3 * READY_PER_PROCESS and big == READY_TIMEOUT + 101 * READY_PER_PROCESS
    assert 'for 101' in why_big and 'per process' in why_big and 'for 3' in why_small
    one, why_one = ready_deadline(101, processes=False)
    assert one == READY_TIMEOUT + 101 * READY_PER_NODE and 'one process' in why_one
    assert READY_PER_NODE < READY_PER_PROCESS


def test_a_long_list_is_cut_with_a_count():
    names = [f'sensor_{k}' for k in range(20)]
    assert listing(names[:2]) == 'sensor_0, sensor_1'
    assert listing(names).endswith('sensor_7 and 12 more')
