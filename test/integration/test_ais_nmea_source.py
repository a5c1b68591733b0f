"""ais_nmea_source live: real NMEA over UDP on localhost → one track per MMSI; the run's one map datum."""

from __future__ import annotations

import socket

import numpy as np
import pytest
from diagnostic_msgs.msg import DiagnosticArray
from pyais.encode import encode_dict
from rclpy.node import Node
from rclpy.parameter import Parameter
from sensor_msgs.msg import NavSatFix

from track_core.ais.datum import Datum
from track_msgs.msg import TrackArray
from track_msgs_py.ais import datum_to_navsatfix
from track_msgs_py.qos import ESTIMATE_QOS, STATIC_QOS
from track_msgs_py.topics import AIS_NMEA_SHIPS, AIS_NMEA_TRACKS, MAP_DATUM
from track_msgs_py.track_arrays import array_to_tracks
from track_nodes.fusion.ais_nmea_source import AisNmeaSourceNode

pytestmark = pytest.mark.integration

ORIGIN = (50.8, -1.2)
SHIPS = {235000001 + k: (50.8 + 0.01 * k, -1.2 + 0.015 * k) for k in range(5)}


def _nmea(fields, **kw) -> list[str]:
    return encode_dict({**fields, 'msg_type': fields['type']}, talker_id='AI', sentence_type='VDM', **kw)


def _capture() -> list[str]:
    """Each ship twice (class A and B), a two-part static message, and three bad lines."""
    lines = []
    for rep in range(2):
        for k, (mmsi, (lat, lon)) in enumerate(SHIPS.items()):
            kind = 18 if k % 2 else 1
            lines += _nmea({'type': kind, 'mmsi': mmsi, 'lat': lat + 1e-4 * rep, 'lon': lon, 'speed': 8.0,
                            'course': 30.0, 'heading': 511, 'accuracy': k % 2})
    lines += _nmea({'type': 5, 'mmsi': 235000001, 'shipname': 'RED FUNNEL', 'ship_type': 60, 'callsign': 'GABC'},
                   seq_id=2)
    good = lines[0]
    lines += [good[:-2] + ('00' if good[-2:] != '00' else '11'), good[:20], '!AIVDM,1,1,,A,' + 'x' * 10]
    return lines


def _sink(ros):
    got: dict[str, list] = {'tracks': [], 'ships': [], 'datum': []}
    sink = ros.add(Node('sink', context=ros.context))
    sink.create_subscription(TrackArray, AIS_NMEA_TRACKS.lstrip('/'), got['tracks'].append, ESTIMATE_QOS)
    sink.create_subscription(DiagnosticArray, AIS_NMEA_SHIPS.lstrip('/'), got['ships'].append, STATIC_QOS)
    sink.create_subscription(NavSatFix, MAP_DATUM.lstrip('/'), got['datum'].append, STATIC_QOS)
    return got


def _node(ros, name='ais_nmea_source', **params):
    over = {'udp_port': 0, **params}   # 0 here: the test picks a free port below
    return ros.add(AisNmeaSourceNode(node_name=name, context=ros.context,
                                     parameter_overrides=[Parameter(k, value=v) for k, v in over.items()]))


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(('127.0.0.1', 0))
        return s.getsockname()[1]


def test_nmea_over_udp_gives_one_track_per_mmsi(ros):
    port = _free_port()
    got = _sink(ros)   # the listener first, and matched before a report is read: nothing published is lost
    node = _node(ros, udp_port=port, origin=list(ORIGIN))
    assert ros.spin_until(lambda: node.pub.get_subscription_count() > 0, timeout=30)
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as tx:
        for line in _capture():          # one sentence per datagram, as receivers send them
            tx.sendto((line + '\r\n').encode(), ('127.0.0.1', port))
    assert ros.spin_until(lambda: len(got['tracks']) >= 2 * len(SHIPS) and got['ships'], timeout=20), \
        (len(got['tracks']), node.decoder.refused)
    datum = Datum(*ORIGIN)
    ids = {}
    for msg in got['tracks']:
        _, tids, sources, x, P = array_to_tracks(msg)
        assert msg.header.frame_id == 'map' and len(tids) == 1 and sources == ['ais_nmea_source']
        ids.setdefault(tids[0], []).append((x[0], P[0]))
    assert set(ids) == {str(m) for m in SHIPS}                                   # one track per MMSI
    for mmsi, (lat, lon) in SHIPS.items():
        x, P = ids[str(mmsi)][0]
        e, n = datum.forward(lat, lon)
        assert abs(x[0] - e) < 0.5 and abs(x[2] - n) < 0.5
        assert P[0, 0] in (25.0, 225.0) and P[1, 1] < 1.0                       # σ 5 / 15 m; velocity estimated
    statuses = {s.name: {kv.key: kv.value for kv in s.values} for s in got['ships'][-1].status}
    assert statuses['235000001']['name'] == 'RED FUNNEL' and statuses['235000001']['ship_type'] == '60'
    assert ros.spin_until(lambda: sum(node.decoder.refused.values()) >= 3, timeout=5), node.decoder.refused
    assert node.refusals.total() >= 3                               # counted and refused through TrackNode.refuse
    assert got['datum'] and got['datum'][-1].latitude == ORIGIN[0]


def test_first_fix_sets_the_datum_and_a_second_origin_is_refused(ros, tmp_path):
    capture = tmp_path / 'capture.nmea'
    capture.write_text(''.join(line + '\n' for line in _capture()))
    got = _sink(ros)   # the listener first; the file is read after datum_wait, by when the two have matched
    first = _node(ros, 'first', file=str(capture), datum_wait=5.0)
    assert ros.spin_until(lambda: first.pub.get_subscription_count() > 0, timeout=30)
    assert ros.spin_until(lambda: got['datum'] and len(got['tracks']) >= 2 * len(SHIPS), timeout=30), \
        (len(got['tracks']), first.published)
    lat0, lon0 = SHIPS[235000001]
    assert (got['datum'][-1].latitude, got['datum'][-1].longitude) == (lat0, lon0)      # the first fix
    assert first.datum.same_as(lat0, lon0)
    # a second node with another origin hears the run's (earlier) datum and refuses its reports, naming both
    other = _node(ros, 'second', file=str(capture), origin=[50.0, -1.0])
    assert ros.spin_until(lambda: other.conflict is not None and other.decoder.sentences >= len(_capture()),
                          timeout=20)
    assert '(50.0000000°, -1.0000000°)' in other.conflict and f'({lat0:.7f}°, {lon0:.7f}°)' in other.conflict
    assert other.published == 0 and any('datum' in k for k in other.refusals.by_key())
    # a third node without an origin takes the run's datum
    third = _node(ros, 'third', file=str(capture))
    assert ros.spin_until(lambda: third.published >= 2 * len(SHIPS), timeout=20)
    assert third.datum.same_as(lat0, lon0) and third.conflict is None


def test_a_stopped_feed_is_reported(ros):
    node = _node(ros, udp_port=_free_port(), silence=0.3, origin=list(ORIGIN))
    health = []
    sink = ros.add(Node('health', context=ros.context))
    sink.create_subscription(DiagnosticArray, '/diagnostics', health.append, 10)
    assert ros.spin_until(lambda: node.watch.quiet and any(
        s.message == 'NMEA feed silent' for m in health for s in m.status), timeout=10)


def test_datum_message_round_trip():
    msg = datum_to_navsatfix(12.5, *ORIGIN)
    assert (msg.latitude, msg.longitude, msg.header.frame_id) == (*ORIGIN, 'map')


def test_a_capture_played_over_udp_keeps_its_spacing_on_the_run_clock(ros, tmp_path):
    """nmea_player plays a timed capture at its pace, restamped on its clock: the source stamps each report with
    the play time (stamp:=receiver), so the reports keep the capture's spacing to the millisecond."""
    from track_msgs_py.stamps import stamp_to_sec
    from track_nodes.fusion.nmea_player import NmeaPlayerNode

    t0 = 1452603731.0
    lines, times = [], []
    for k, (mmsi, (lat, lon)) in enumerate(list(SHIPS.items()) * 2):
        t = t0 + 0.25 * k + (0.5 if k >= len(SHIPS) else 0.0)
        times.append(t)
        lines += [f'{t:.3f} {s}' for s in _nmea({'type': 1, 'mmsi': mmsi, 'lat': lat, 'lon': lon, 'speed': 8.0,
                                                  'course': 30.0, 'heading': 511, 'accuracy': 1})]
    capture = tmp_path / 'capture.nmea'
    capture.write_text('\n'.join(lines) + '\n')
    port = _free_port()
    source = _node(ros, udp_port=port, origin=list(ORIGIN), stamp='receiver', datum_wait=0.0)
    got = _sink(ros)
    player = ros.add(NmeaPlayerNode(node_name='nmea_player', context=ros.context, parameter_overrides=[
        Parameter('file', value=str(capture)), Parameter('port', value=port), Parameter('tick', value=0.05),
        Parameter('duration', value=10.0)]))
    assert ros.spin_until(lambda: len(got['tracks']) >= len(lines), timeout=20), (len(got['tracks']), player.sent)
    stamps = np.array([stamp_to_sec(m.header.stamp) for m in got['tracks']])
    np.testing.assert_allclose(np.diff(stamps), np.diff(times), atol=2e-3)        # the capture's spacing
    assert stamps[0] == pytest.approx(player.steps.origin, abs=2e-3)               # its first line at the origin
    assert {m.tracks[0].id for m in got['tracks']} == {str(m) for m in SHIPS}
    assert source.published == len(lines) and not source.refusals.total()
