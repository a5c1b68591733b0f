"""RefusalCounter: every refusal counted per reason; a new kind logged at once, then one summary line per period."""

from track_nodes.base.refusals import RefusalCounter, reason_kind


def test_reason_kind_is_the_field():
    assert reason_kind('pose.covariance: covariance is not positive definite') == 'pose.covariance'
    assert reason_kind('busy') == 'busy'
    assert reason_kind("bad handoff magic/version b'\\xa7\\xb3pm'/140, expected b'IDSQ'") == 'bad handoff magic/version'
    assert reason_kind('handoff length 659 != 1318 for 159 cells') == 'handoff length'
    assert reason_kind('unusable MOVE: signal lost after 3 reads') == 'unusable MOVE'


def test_a_flood_costs_one_line_per_period_with_the_count():
    c = RefusalCounter(throttle=5.0)
    lines = [c.refuse('/t', f'pose.pose.position: x={i} is beyond the bound', now=0.001 * i) for i in range(10_000)]
    said = [(i, line) for i, line in enumerate(lines) if line is not None]
    assert [i for i, _ in said] == [0, 1, 5001]  # the new kind; the first summary; 5 s later
    assert 'x=0 is beyond' in said[0][1] and 'new kind' in said[0][1]
    assert 'pose.pose.position x5000 (5002 in all; latest: pose.pose.position: x=5001' in said[2][1]
    assert c.counts[('/t', 'pose.pose.position')] == 10_000 and c.total() == 10_000


def test_many_kinds_share_one_summary_line():
    c = RefusalCounter(throttle=5.0)
    firsts = [c.refuse('/a', f'f{k}: bad', 0.0) for k in range(20)]
    assert all(firsts)  # each new kind at once
    assert c.refuse('/a', 'f0: worse', 0.5) is not None  # the first summary is due at once
    later = [c.refuse('/a', f'f{k}: worse', 1.0 + 0.01 * k) for k in range(20)]
    assert later == [None] * 20
    line = c.flush(6.0)
    assert line.startswith('refused in the last 6 s: ') and 'and 14 more kinds' in line
    assert c.flush(7.0) is None  # nothing new


def test_kinds_and_topics_are_counted_separately():
    c = RefusalCounter(throttle=5.0)
    assert c.refuse('/a', 'x: bad', 0.0) and c.refuse('/a', 'y: bad', 0.0) and c.refuse('/b', 'x: bad', 0.0)
    assert c.by_key() == {'/a x': 1, '/a y': 1, '/b x': 1}
    c.refuse('/a', 'x: worse', 1.0)
    assert c.by_key()['/a x'] == 2
