"""AIS scenario (issue 8, part 2): two ais_source nodes and the fusion node in-process on /clock.

A short stretch of the real Solent data (150 s, the patrol every 10 s instead of 30 s so that each
pair gets 15 common instants) with the scenario's parameters otherwise:

- the fusion node scores exactly the pair-instants of the core (``track_core.ais.PairTable``) with
  the same numbers, and its per-instant verdicts give the core's same-ship decisions;
- the same ship is associated across the two sources (high recall and precision after one-to-one);
- reports are TrackArrays in ``map`` carrying local track ids only (``r017``), drawn on ``<prefix>/markers``
  (a disc and an id label per ship, every frame placed); the MMSI is only on the truth topics;
- the recorded bag's summary (``summary.ais_metrics``) reports the core's precision/recall/F1;
- fusion drops multi-track pose reports (``pose_track_topics``) without a track id or with an unknown frame.
"""

from __future__ import annotations

import re

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseWithCovarianceStamped
from rclpy.node import Node
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock

from track_core.ais import PairTable, default_path, evaluate
from track_msgs.msg import PairScoreArray
from track_msgs_py.odometry import position_to_pose_cov
from track_msgs_py.qos import CLOCK_QOS, ESTIMATE_QOS, STATIC_QOS
from track_msgs_py.records.fusion import AisTruthEntry, FusionPairs
from track_msgs_py.stamps import sec_to_stamp, stamp_to_sec
from track_msgs_py.topics import (
    CLOCK,
    FUSION_FUSED,
    FUSION_SCORES,
    ais_markers_topic,
    ais_reports_topic,
    ais_truth_topic,
)
from track_nodes.fusion.ais_source import AisSourceNode
from track_nodes.fusion.fusion import FusionNode

pytestmark = pytest.mark.skipif(not default_path().is_file(), reason='shared AIS data not found')

DURATION = 150.0
OVERRIDES = {'radar': {'duration': DURATION}, 'patrol': {'duration': DURATION, 'period': 10.0}, 'fusion': {}}


def _node(ros, repo, cls, name):
    params = [Parameter('use_sim_time', value=True), *[Parameter(k, value=v) for k, v in OVERRIDES[name].items()]]
    return ros.add(cls(node_name=name, context=ros.context, parameter_overrides=params,
                       cli_args=['--ros-args', '--params-file', str(repo / 'config/ais.yaml')]))


@pytest.fixture
def ais_run(ros, repo, tmp_path):
    from track_nodes.bag.recorder import RecorderNode

    radar = _node(ros, repo, AisSourceNode, 'radar')
    patrol = _node(ros, repo, AisSourceNode, 'patrol')
    fusion = _node(ros, repo, FusionNode, 'fusion')
    received = {'n': 0, 'arrays': 0}
    on_track_array = fusion._on_track_array

    def counting(topic, msg):
        received['n'] += len(msg.tracks)
        received['arrays'] += 1
        on_track_array(topic, msg)

    fusion._on_track_array = counting  # the subscriptions look the method up at call time
    sink = ros.add(Node('ais_sink', context=ros.context))
    got = {'scores': [], 'truth': {}}
    sink.create_subscription(PairScoreArray, FUSION_SCORES, got['scores'].append, ESTIMATE_QOS)
    for src in (radar, patrol):
        sink.create_subscription(DiagnosticArray, ais_truth_topic(src.p.prefix),
                                 lambda m: got['truth'].update({s.name: s for s in m.status}), STATIC_QOS)
    bag = tmp_path / 'ais_bag'
    recorder = ros.add(RecorderNode(context=ros.context, parameter_overrides=[
        Parameter('use_sim_time', value=True), Parameter('bag', value=str(bag)),
        Parameter('regex', value='^/(ais|fusion)/')]))
    clock = ros.add(Node('test_clock', context=ros.context)).create_publisher(Clock, CLOCK, CLOCK_QOS)
    topics = {radar.topic, patrol.topic, ais_truth_topic('/ais/radar'), ais_truth_topic('/ais/patrol'), FUSION_SCORES}
    assert ros.spin_until(lambda: topics <= set(recorder.subscriptions_by_topic)
                          and radar.pub.get_subscription_count() >= 2, timeout=15)

    def recorded(topic):
        return recorder.message_counts().get(topic, 0)

    # /clock visits every report stamp and every fusion tick (5 s); the timers catch up in between
    # (and 0.5 first: each source's origin is the whole second of its first clock reading, here 0)
    events = np.unique(np.round(np.concatenate([[0.5], radar.stamps, patrol.stamps,
                                                np.arange(5.0, DURATION + 1e-9, 5.0)]), 6))
    n_ticks = 0
    for t in events.tolist():
        clock.publish(Clock(clock=sec_to_stamp(t)))
        want = {s: int(np.searchsorted(s.stamps, t + 1e-9, side='right')) for s in (radar, patrol)}
        # a fusion tick (every 5 s) with patrol reports 0.5 s before it publishes one scores message
        if abs(t / 5.0 - round(t / 5.0)) < 1e-9 and np.any(np.abs(patrol.stamps - (t - 0.5)) < 1e-9):
            n_ticks += 1

        def done(want=want, n_ticks=n_ticks):
            pub = sum(want.values())
            instants = sum(np.unique(s.stamps[:n]).size for s, n in want.items())   # one array per instant
            return (all(s.next == n and s.steps.origin == 0.0 for s, n in want.items()) and received['n'] == pub
                    and recorded(radar.topic) + recorded(patrol.topic) == instants
                    and received['arrays'] == instants and len(got['scores']) == n_ticks
                    and recorded(FUSION_SCORES) == n_ticks)

        assert ros.spin_until(done, timeout=20), f'step t={t} not completed'
    recorder.close()
    return radar, patrol, fusion, got, bag


def _node_scores(got, radar, patrol):
    """{(radar local index, patrol local index, report time): (score, associated)} from /fusion/scores."""
    r_idx = {f'{radar.topic}/{i}': k for k, i in enumerate(radar.reports.ids)}
    p_idx = {f'{patrol.topic}/{i}': k for k, i in enumerate(patrol.reports.ids)}
    out = {}
    for arr in got['scores']:
        t_report = round(stamp_to_sec(arr.header.stamp) - 0.5, 6)
        for pair, score, _, _, associated in FusionPairs.from_msg(arr).rows():
            r, p = pair[::-1] if pair[0] in p_idx else pair
            out[(r_idx[r], p_idx[p], t_report)] = (score, associated)
    return out


def test_sources_and_fusion_in_process(ais_run):
    """One run (it takes ~15 s), three checks: the core's numbers, local ids only, the recorded summary."""
    from track_core.ais.association import SHORT_PAIR_RATE, SHORT_PAIR_WEIGHT
    from track_nodes.report.read import read_topics
    from track_nodes.report.summary import SCENARIO_METRICS, summarize

    radar, patrol, fusion, got, bag = ais_run
    a, b = radar.reports, patrol.reports
    table = PairTable(a, b)
    g, _ = table.score('exact')

    # 1. the fusion node scores exactly the core's pair-instants, with the core's numbers and verdicts
    core = {(int(a.track[i]), int(b.track[j]), round(float(a.t[i]) - radar.p.start, 6)): float(s)
            for i, j, s in zip(table.pi.ia, table.pi.ib, g, strict=True)}
    node = _node_scores(got, radar, patrol)
    assert set(node) == set(core) and len(node) > 10_000
    np.testing.assert_allclose([node[k][0] for k in core], list(core.values()), rtol=0, atol=1e-12)  # float64
    assert all(node[k][1] == (core[k] >= 0.5) for k in core)      # window 1: the instant verdict
    assert not fusion.dropped
    # the same ship is associated across the sources (the core's decisions on these scores)
    m = evaluate(a, b, table.decide(g, window=1, threshold=0.5, one_to_one=True, prior_weight=SHORT_PAIR_WEIGHT,
                                    prior_rate=SHORT_PAIR_RATE))  # the short-pair rule, as the summary
    print(f'{len(a.ids)} radar / {len(b.ids)} patrol tracks: precision {m.precision:.3f} recall {m.recall:.3f} '
          f'F1 {m.f1:.3f}')
    assert m.recall >= 0.85 and m.precision >= 0.85

    # 2. reports are arrays in map carrying local track ids only; the MMSI travels on the truth topics
    reports = read_topics(bag, {radar.topic, patrol.topic})
    assert {m.header.frame_id for msgs in reports.values() for m in msgs} == {'map'}
    ids = {k.id for msgs in reports.values() for m in msgs for k in m.tracks}
    assert sum(len(m.tracks) for msgs in reports.values() for m in msgs) == len(a) + len(b)
    for src, msgs in ((radar, reports[radar.topic]), (patrol, reports[patrol.topic])):
        assert len(msgs) == np.unique(src.stamps).size                 # one array per report instant
        assert all(len({k.id for k in m.tracks}) == len(m.tracks) for m in msgs)
    from track_nodes.bag.check import check_bag
    res = check_bag(bag)  # the fusion's markers and arrays pass the bag check
    assert res.ok, res.problems
    assert any(len(m.tracks) for m in read_topics(bag, {FUSION_FUSED})[FUSION_FUSED])  # the fused pairs
    assert all(re.fullmatch(r'[rp]\d{3}', i) for i in ids)
    assert ids == set(a.ids) | set(b.ids)
    # drawable: one MarkerArray per instant, a disc and a label per reported ship, in map
    drawn = read_topics(bag, {ais_markers_topic('/ais/radar')})[ais_markers_topic('/ais/radar')]
    assert len(drawn) == len(reports[radar.topic])
    first = drawn[0].markers
    assert {m.header.frame_id for m in first} == {'map'}
    assert sorted(m.text for m in first if m.ns == 'r_ids') == sorted(k.id for k in reports[radar.topic][0].tracks)
    names = {f'{s.topic}/{i}' for s in (radar, patrol) for i in s.reports.ids}
    assert set(got['truth']) == names                              # named like the fusion track ids
    truth = read_topics(bag, {ais_truth_topic('/ais/radar')})[ais_truth_topic('/ais/radar')]
    assert len(truth) == 1 and stamp_to_sec(truth[0].header.stamp) == radar.steps.origin  # at the origin
    mmsi = {AisTruthEntry.from_status(st).mmsi for st in got['truth'].values()}
    assert mmsi == set(a.mmsi) | set(b.mmsi)

    # 3. the summary of the recorded bag reports the core's precision/recall/F1
    lines = SCENARIO_METRICS['ais'](bag)
    print('\n'.join(lines))
    assert lines[0].startswith('ais: method exact')
    one = next(line for line in lines if 'one-to-one' in line)
    assert f'F1 {m.f1:.3f}' in one and f'TP {m.tp}, FP {m.fp}, FN {m.fn}' in one
    assert any('/ais/radar/reports' in line for line in summarize(bag, 'ais'))
    # 4. every frame is placed (the frame check takes a frame id whole: a "map#r017" would fail here)
    from track_nodes.bag.frames import check_frames

    assert check_frames(bag, stamps=True) == []


def test_reports_without_a_track_id_or_with_a_bad_frame_are_dropped(ros, repo):
    fusion = ros.add(FusionNode(node_name='fusion', context=ros.context,
                                cli_args=['--ros-args', '--params-file', str(repo / 'config/ais.yaml')],
                                parameter_overrides=[Parameter('rate', value=20.0),
                                                     Parameter('stale_after', value=5.0),
                                                     Parameter('track_array_topics', value=['']),
                                                     Parameter('pose_track_topics', value=[
                                                         '/ais/radar/reports', '/ais/patrol/reports'])]))
    node = ros.add(Node('bad_source', context=ros.context))
    pubs = {s: node.create_publisher(PoseWithCovarianceStamped, ais_reports_topic(s), ESTIMATE_QOS)
            for s in ('/ais/radar', '/ais/patrol')}
    assert ros.spin_until(lambda: all(p.get_subscription_count() > 0 for p in pubs.values()))
    t = node.get_clock().now().nanoseconds * 1e-9
    R = np.diag([100.0, 25.0])
    for frame in ('map', 'odom#r001', 'map#'):
        pubs['/ais/radar'].publish(position_to_pose_cov(t, np.zeros(2), R, frame))
    pubs['/ais/radar'].publish(position_to_pose_cov(t, np.zeros(2), R, 'map#r001'))
    pubs['/ais/patrol'].publish(position_to_pose_cov(t, np.array([5.0, 0.0]), R, 'map#p001'))
    assert ros.spin_until(lambda: fusion.dropped.get('/ais/radar/reports', 0) == 3
                          and {'/ais/radar/reports/r001', '/ais/patrol/reports/p001'} <= set(fusion.core.table.latest))
    assert fusion.core.source['/ais/radar/reports/r001'] == '/ais/radar/reports'
    assert ros.spin_until(lambda: ('/ais/radar/reports/r001', '/ais/patrol/reports/p001') in fusion.core.history
                          or ('/ais/patrol/reports/p001', '/ais/radar/reports/r001') in fusion.core.history)


@pytest.mark.parametrize(('over', 'match'), [
    ({'file': '/nonexistent/ais.csv'}, 'AIS file not found'),
    ({'start': 1e6}, 'after the end of the data'),
    ({'site': [95.0, 0.0]}, 'parameter site'),
    ({'sigma_major': 5.0, 'sigma_minor': 10.0}, 'sigma_minor'),
    ({'id_prefix': 'r#'}, 'id_prefix'),
])
def test_bad_source_parameters_stop_the_node_with_one_line(ros, over, match):
    with pytest.raises((ValueError, OSError), match=match):
        AisSourceNode(node_name='radar', context=ros.context,
                      parameter_overrides=[Parameter(k, value=v) for k, v in over.items()])


def test_a_source_on_another_export_with_a_column_mapping(ros, repo):
    """The node reads any CSV through ``columns`` (and its default site is on that traffic's hull)."""
    csv = repo / 'test/unit/track_core/ais/data/custom_semicolon.csv'
    node = AisSourceNode(node_name='radar', context=ros.context, parameter_overrides=[
        Parameter('file', value=str(csv)), Parameter('duration', value=200.0), Parameter('dropout', value=0.0),
        Parameter('columns', value='time=ts;mmsi=ship;lat=lat;lon=lon;cog=;sog=;time_format=epoch_s;'
                                   'delimiter=semicolon')])
    try:
        rep = node.reports
        assert sorted(rep.mmsi.tolist()) == [211000001, 211000002] and len(rep) == 2 * 41   # every 5 s, 0..200 s
        assert np.all(np.abs(rep.truth).max(0) < [3e3, 6e4])       # in this traffic's own tangent plane
    finally:
        node.destroy_node()


def _datum_sink(ros):
    from sensor_msgs.msg import NavSatFix
    from tf2_msgs.msg import TFMessage

    from track_msgs_py.tf import TF_STATIC_QOS
    from track_msgs_py.topics import MAP_DATUM, TF_STATIC

    got = {'datum': [], 'tf_static': []}
    sink = ros.add(Node('datum_sink', context=ros.context))
    sink.create_subscription(NavSatFix, MAP_DATUM, got['datum'].append, STATIC_QOS)
    sink.create_subscription(TFMessage, TF_STATIC, got['tf_static'].append, TF_STATIC_QOS)
    return got


def test_sources_share_the_run_datum_and_a_second_origin_is_refused(ros, tmp_path):
    """The first source's datum (its file's centroid) is the run's, latched with earth → map; a source on another
    file takes it (its reports projected about it); a source with another origin refuses its reports, naming both."""
    from track_core.ais import read_ais
    from track_core.ais.datum import Datum
    from track_msgs.msg import TrackArray
    from track_msgs_py.track_arrays import array_to_tracks

    got = _datum_sink(ros)
    short = {'duration': 20.0, 'period': 1.0, 'dropout': 0.0}
    first = ros.add(AisSourceNode(node_name='radar', context=ros.context, parameter_overrides=[
        Parameter(k, value=v) for k, v in {**short, 'offset': 0.5}.items()]))
    assert ros.spin_until(lambda: first.next > 0 and got['datum'] and got['tf_static'], timeout=15)
    lat0, lon0 = read_ais(None).centroid()
    run = got['datum'][-1]
    assert (run.latitude, run.longitude) == (lat0, lon0) and first.map_datum.datum.same_as(lat0, lon0)
    earth = [tr for m in got['tf_static'] for tr in m.transforms if tr.child_frame_id == 'map']
    assert earth and earth[-1].header.frame_id == 'earth'
    np.testing.assert_allclose([earth[-1].transform.translation.x, earth[-1].transform.translation.y],
                               Datum(lat0, lon0).earth_pose()[0][:2])

    # a source on another file, no origin: the run's datum, not its own centroid (8 km away)
    csv = tmp_path / 'near.csv'
    csv.write_text('ts;ship;lon;lat\n' + ''.join(f'{1700000000 + 10 * k};{m};{lon};{lat}\n' for k in range(40)
                                                  for m, lat, lon in ((211000001, 50.70, -1.45),
                                                                      (211000002, 50.72, -1.40))))
    reports = []
    other_file = ros.add(AisSourceNode(node_name='near', context=ros.context, parameter_overrides=[
        Parameter(k, value=v) for k, v in {**short, 'offset': 2.0, 'file': str(csv), 'prefix': '/ais/near',
                                           'columns': 'time=ts;mmsi=ship;lat=lat;lon=lon;cog=;sog=;'
                                                      'time_format=epoch_s;delimiter=semicolon'}.items()]))
    ros.add(Node('near_sink', context=ros.context)).create_subscription(
        TrackArray, '/ais/near/reports', reports.append, ESTIMATE_QOS)
    assert ros.spin_until(lambda: len(reports) >= 2, timeout=15)
    assert other_file.sim_datum.same_as(lat0, lon0) and other_file.map_datum.conflict is None
    want = Datum(lat0, lon0).forward([50.70, 50.72], [-1.45, -1.40])
    for msg in reports:
        _, _, _, x, _ = array_to_tracks(msg)
        assert all(np.min(np.linalg.norm(want - x[k, [0, 2]], axis=1)) < 100.0 for k in range(len(x)))

    # a source with an explicit other origin: refused, one line naming both datums
    refused = []
    ros.add(Node('elsewhere_sink', context=ros.context)).create_subscription(
        TrackArray, '/ais/elsewhere/reports', refused.append, ESTIMATE_QOS)
    other = ros.add(AisSourceNode(node_name='elsewhere', context=ros.context, parameter_overrides=[
        Parameter(k, value=v) for k, v in {**short, 'offset': 2.0, 'origin': [50.0, -1.0],
                                           'prefix': '/ais/elsewhere'}.items()]))
    assert ros.spin_until(lambda: other.next > 2 and other.pub.get_subscription_count() > 0, timeout=15)
    reason = other.map_datum.problem()
    assert '(50.0000000°, -1.0000000°)' in reason and f'({lat0:.7f}°, {lon0:.7f}°)' in reason
    assert list(other.refusals.by_key()) == ['/ais/elsewhere/reports datum'] and refused == []
