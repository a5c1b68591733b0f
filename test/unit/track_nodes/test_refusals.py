"""RefusalCounter: every refusal counted per reason; at most one line per reason per throttle period."""

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
    assert sum(line is not None for line in lines) == 2  # t = 0 and t = 5 s
    assert c.counts[('/t', 'pose.pose.position')] == 10_000 and c.total() == 10_000
    second = next(line for line in lines[1:] if line is not None)
    assert '(5000 since the last line, 5001 in all)' in second


def test_kinds_and_topics_are_throttled_separately():
    c = RefusalCounter(throttle=5.0)
    assert c.refuse('/a', 'x: bad', 0.0) and c.refuse('/a', 'y: bad', 0.0) and c.refuse('/b', 'x: bad', 0.0)
    assert c.refuse('/a', 'x: worse', 1.0) is None
    assert c.by_key() == {'/a x': 2, '/a y': 1, '/b x': 1}
