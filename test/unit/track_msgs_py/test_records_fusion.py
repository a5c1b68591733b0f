"""Fusion records: the pairs and fused tracks of an instant and the AIS truth entry round-trip; the markers."""

from __future__ import annotations

import numpy as np
import pytest
from rclpy.serialization import deserialize_message, serialize_message

from track_msgs.msg import FusedTrackArray, PairScoreArray
from track_msgs_py.diagnostics import DIAG_OK, diagnostic_status
from track_msgs_py.records import RecordError
from track_msgs_py.records.fusion import AisTruthEntry, FusedTracks, FusionPairs


def _pairs() -> FusionPairs:
    return FusionPairs(12.5, ['/radar/t0', '/radar/t1'], ['/patrol/t1', '/patrol/t0'], np.array([0.1234564, 0.0]),
                       np.array([1.0, 0.0]), np.array([7, 1]), np.array([True, False]), 'exact', 'geometric', 10, 0.5)


def test_pair_scores_round_trip_through_serialization():
    rec = _pairs()
    msg = deserialize_message(serialize_message(rec.to_msg()), PairScoreArray)
    assert (msg.method, msg.combine, msg.window, msg.threshold) == ('exact', 'geometric', 10, 0.5)
    back = FusionPairs.from_msg(msg)
    assert back.t == 12.5 and list(back.rows()) == list(rec.rows())   # float64: every digit travels
    assert next(back.rows()) == (('/radar/t0', '/patrol/t1'), 0.1234564, 1.0, 7, True)
    assoc = back.select(back.associated)
    assert len(assoc) == 1 and assoc.a == ['/radar/t0'] and assoc.method == 'exact'


def test_a_pair_without_track_ids_is_one_line():
    msg = _pairs().to_msg()
    msg.pairs[1].b = ''
    with pytest.raises(RecordError, match='pair 1 has an empty track id'):
        FusionPairs.from_msg(msg)


def test_fused_tracks_round_trip_through_serialization():
    P = np.array([[[4.0, 0.5], [0.5, 2.0]], [[9.0, -1.0], [-1.0, 3.0]]])
    mu = np.array([[1.0, 2.0], [-3.0, 4.5]])
    rec = FusedTracks(3.0, ['/radar/t0', '/radar/t1'], ['/patrol/t1', '/patrol/t0'], mu, P)
    back = FusedTracks.from_msg(deserialize_message(serialize_message(rec.to_msg()), FusedTrackArray))
    assert back.t == 3.0 and back.a == rec.a and back.b == rec.b
    np.testing.assert_array_equal(back.mu, rec.mu)
    np.testing.assert_array_equal(back.P, P)
    empty = FusedTracks.from_msg(FusedTracks(1.0, [], [], np.zeros((0, 2)), np.zeros((0, 2, 2))).to_msg())
    assert len(empty) == 0 and empty.mu.shape == (0, 2)


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
    from track_core.fusion import FusedPair, Instant, PairScore
    from track_core.geofeasibility import ellipse_to_gaussian
    from track_msgs_py.markers.fusion import FUSED_NS, LINK_BANDS, LINKS_NS, TRACKS_NS, FusionMarkers

    markers = FusionMarkers(lifetime=1.0)
    x0, y0, r_x, r_y, phi = 10.0, 5.0, 6.0, 2.0, np.pi / 6          # 2σ axes, bearing of the major axis
    mu_b, R_b = ellipse_to_gaussian(x0, y0, r_x, r_y, phi)
    mu, R = np.array([[0.0, 0.0], mu_b]), np.array([np.eye(2), R_b])
    q = PairScore('b', 'a', 0, 1, 0.9, 0.75, 3, True)
    fused = (FusedPair('b', 'a', np.array([5.0, 2.5]), np.eye(2)),)
    first = markers.build(Instant(2.0, ['b', 'a'], mu, R, (q,), fused))
    assert [(m.ns, m.id) for m in first.markers] == [(TRACKS_NS, 0), (TRACKS_NS, 1), (FUSED_NS, 0)] + [
        (LINKS_NS, k) for k in range(LINK_BANDS)]
    assert [(p.x, p.y) for p in first.markers[2].points] == [(5.0, 2.5)]
    disc = first.markers[1]
    assert (disc.pose.position.x, disc.pose.position.y) == pytest.approx((x0, y0))
    assert (disc.scale.x, disc.scale.y) == pytest.approx((2 * r_x, 2 * r_y))         # diameters of the 2σ ellipse
    yaw = 2 * np.arctan2(disc.pose.orientation.z, disc.pose.orientation.w)
    assert np.cos(yaw) == pytest.approx(np.sin(phi)) and np.sin(yaw) == pytest.approx(np.cos(phi))
    links = first.markers[3:]
    assert [len(m.points) for m in links] == [0, 0, 0, 2, 0]            # combined 0.75: the band [0.6, 0.8)
    assert [(p.x, p.y) for p in links[3].points] == [(0.0, 0.0), (x0, y0)]
    assert (links[3].color.r, links[3].color.g) == pytest.approx((0.3, 0.7))
    again = markers.build(Instant(3.0, ['a'], mu[1:], R[1:]))
    assert again.markers[0].id == 1 and not any(m.points for m in again.markers[1:])  # 'a' keeps its id; no link
    assert again.markers[0].lifetime.sec == 1
