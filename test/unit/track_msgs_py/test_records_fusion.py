"""Fusion records: pair score and AIS truth entry round-trip, and are laid out as the old nodes wrote them."""

from __future__ import annotations

import re

import pytest

from track_msgs_py.diagnostics import DIAG_OK, diagnostic_status
from track_msgs_py.records import RecordError, diagnostic_values
from track_msgs_py.records.fusion import AisTruthEntry, FusionPairScore, pair_name, split_pair_name


def test_pair_score_round_trip_and_the_old_layout():
    rec = FusionPairScore(score=0.1234564, combined=1.0, instants=7, associated=True, method='exact')
    st = rec.pair_status('/radar/t0', '/patrol/t1')
    # byte for byte what the pre-record fusion node published (key order included)
    old = diagnostic_status('/radar/t0 | /patrol/t1', DIAG_OK, 'associated',
                            {'score': '0.123456', 'combined': '1.000000', 'instants': '7', 'associated': 'true',
                             'method': 'exact'}, hardware_id='fusion')
    assert st == old
    pair, back = FusionPairScore.read(st)
    assert pair == ('/radar/t0', '/patrol/t1')
    assert back == FusionPairScore(0.123456, 1.0, 7, True, 'exact')  # 6 decimals travel
    assert FusionPairScore.read(back.pair_status(*pair)) == (pair, back)
    st = FusionPairScore(0.0, 0.25, 1, False, 'mc').pair_status('a', 'b')
    assert st.message == 'not associated' and diagnostic_values(st)['associated'] == 'false'


def test_pair_names():
    assert split_pair_name(pair_name('/a/x', '/b/y')) == ('/a/x', '/b/y')
    for bad in ('/a/x', ' | /b', '/a | '):
        with pytest.raises(RecordError, match=re.escape('not "<track> | <track>"')):
            split_pair_name(bad)


def test_bad_pair_score_values_are_one_line():
    st = FusionPairScore(0.5, 0.5, 2, True, 'glr').pair_status('a', 'b')
    st.values[3].value = 'yes'
    with pytest.raises(RecordError, match="fusion pair score: key associated='yes'"):
        FusionPairScore.read(st)
    del st.values[0]
    with pytest.raises(RecordError, match="missing key 'score'"):
        FusionPairScore.read(st)


def test_ais_truth_entry_round_trip_and_the_old_layout():
    rec = AisTruthEntry(mmsi=235012345, reports=42)
    st = rec.truth_status('/ais/radar/reports/r017', hardware_id='radar')
    old = diagnostic_status('/ais/radar/reports/r017', DIAG_OK, 'evaluation only',
                            {'mmsi': '235012345', 'reports': '42'}, hardware_id='radar')
    assert st == old
    assert AisTruthEntry.from_status(st) == rec
    st.values[0].value = '2.5e8'
    with pytest.raises(RecordError, match='mmsi'):
        AisTruthEntry.from_status(st)


def test_fusion_markers_keep_one_id_per_track_and_colour_links_by_score():
    import numpy as np

    from track_core.fusion import Instant, PairScore
    from track_msgs_py.markers.fusion import LINKS_NS, TRACKS_NS, FusionMarkers

    markers = FusionMarkers(lifetime=1.0)
    mu, R = np.array([[0.0, 0.0], [10.0, 5.0]]), np.array([np.eye(2), 4 * np.eye(2)])
    q = PairScore('b', 'a', 0, 1, 0.9, 0.75, 3, True)
    first = markers.build(Instant(2.0, ['b', 'a'], mu, R, (q,)))
    assert [(m.ns, m.id) for m in first.markers] == [(TRACKS_NS, 0), (TRACKS_NS, 1), (LINKS_NS, 0)]
    link = first.markers[-1]
    assert [(p.x, p.y) for p in link.points] == [(0.0, 0.0), (10.0, 5.0)]
    assert (link.colors[0].r, link.colors[0].g) == (0.25, 0.75)
    again = markers.build(Instant(3.0, ['a'], mu[1:], R[1:]))
    assert again.markers[0].id == 1 and not again.markers[-1].points  # 'a' keeps its id; no pair, no link
    assert again.markers[0].lifetime.sec == 1
