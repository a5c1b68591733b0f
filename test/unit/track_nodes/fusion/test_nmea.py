"""NMEA AIS lines → reports: tag blocks, receiver timestamps, multi-part messages, refusals, bounded memory."""

import time

import numpy as np
import pytest
from pyais import TagBlock
from pyais.encode import encode_dict

from track_core.ais.live import ShipTable, position_problem
from track_nodes.fusion.nmea import Decoder, Position, Static

POS = {'type': 1, 'mmsi': 235000001, 'lat': 50.8, 'lon': -1.3, 'speed': 12.5, 'course': 45.0, 'heading': 44,
       'accuracy': 1}


def _nmea(fields, seq_id=None, channel='A', sentence='VDM') -> list[str]:
    fields = {**fields, 'msg_type': fields['type']}     # pyais picks the class by one, fills the payload by the other
    return encode_dict(fields, talker_id='AI', sentence_type=sentence, radio_channel=channel, seq_id=seq_id)


def _tag(**fields) -> str:
    return '\\' + TagBlock.create(**fields).decode() + '\\'


def test_class_a_and_b_positions_and_aivdo():
    d = Decoder()
    for kind in (1, 2, 3, 18):
        (r,), reasons = d.feed(_nmea({**POS, 'type': kind})[0], 0.0)
        assert isinstance(r, Position) and not reasons and r.fields.msg_type == kind
        assert r.fields.mmsi == 235000001 and r.fields.lat == pytest.approx(50.8, abs=1e-5) and r.t is None
    (own,), _ = d.feed(_nmea(POS, sentence='VDO')[0], 0.0)
    assert own.own


def test_static_data_multi_part_and_type_24():
    d = Decoder()
    first, second = _nmea({'type': 5, 'mmsi': 235000001, 'shipname': 'RED FUNNEL', 'ship_type': 60,
                           'callsign': 'GABC'}, seq_id=3)
    assert d.feed(first, 0.0) == ([], []) and len(d.pending) == 1
    (s,), _ = d.feed(second, 0.1)
    assert s == Static(235000001, 'RED FUNNEL', 60, 'GABC', None) and not d.pending
    (a,), _ = d.feed(_nmea({'type': 24, 'mmsi': 235000002, 'partno': 0, 'shipname': 'DINGHY'})[0], 0.2)
    (b,), _ = d.feed(_nmea({'type': 24, 'mmsi': 235000002, 'partno': 1, 'ship_type': 37, 'callsign': 'X1'})[0], 0.3)
    assert (a.name, b.ship_type, b.callsign) == ('DINGHY', 37, 'X1')
    pos, _ = d.feed(_nmea({'type': 19, 'mmsi': 235000003, 'lat': 50.7, 'lon': -1.1, 'speed': 3.0, 'course': 10.0,
                           'heading': 511, 'accuracy': 0, 'shipname': 'YACHT', 'ship_type': 36})[0], 0.4)
    assert [type(r) for r in pos] == [Position, Static] and pos[1].name == 'YACHT'


def test_receiver_times_in_tag_blocks_and_beside_the_sentence():
    d, line = Decoder(), _nmea(POS)[0]
    for text, t in ((_tag(source_station='rx1', receiver_timestamp=1452603731) + line, 1452603731.0),
                    (_tag(receiver_timestamp=1452603731500) + line, 1452603731.5),       # milliseconds
                    ('2016-01-12T13:02:11.5Z ' + line, 1452603731.5),
                    ('1452603731.25 ' + line, 1452603731.25),
                    (line + ',1452603731', 1452603731.0)):
        (r,), reasons = d.feed(text, 0.0)
        assert not reasons and r.t == pytest.approx(t), text


def _flip_checksum(line: str) -> str:
    head, _, chk = line.rpartition('*')
    return f'{head}*{(int(chk, 16) ^ 0x5A):02X}'


@pytest.mark.parametrize('line, field', [
    (_flip_checksum(_nmea(POS)[0]), 'checksum'),
    (_nmea(POS)[0][:25], 'sentence'),                                   # truncated: no checksum
    ('$GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,*47', 'sentence'),
    ('\\s:rx1,c:1452603731*00\\' + _nmea(POS)[0], 'tag_block'),            # tag block checksum wrong
    (_nmea({'type': 5, 'mmsi': 1, 'shipname': 'X'}, seq_id=1)[1], 'fragment'),   # second part alone
    ('!AIVDM,1,1,,A,' + 'w' * 20 + ',0*' + '00', 'checksum'),
])
def test_bad_lines_are_refused_with_their_field(line, field):
    d = Decoder()
    reports, reasons = d.feed(line, 0.0)
    assert reports == [] and len(reasons) == 1 and reasons[0].startswith(f'{field}:'), reasons
    assert d.refused[field] == 1


def test_truncated_payload_and_unknown_type_are_refused():
    line = _nmea(POS)[0]
    head, payload, tail = line.split(',')[:5], line.split(',')[5], line.split(',')[6:]
    short = ','.join([*head, payload[:12], *tail])
    body = short[1:short.rindex('*')]
    chk = 0
    for c in body.encode():
        chk ^= c
    _, reasons = Decoder().feed(f'{short[:short.rindex("*")]}*{chk:02X}', 0.0)
    assert reasons and reasons[0].startswith('payload: truncated'), reasons
    # type 63: six bits all ones, no such AIS message
    body = 'AIVDM,1,1,,A,w0000000000,0'
    chk = 0
    for c in body.encode():
        chk ^= c
    _, reasons = Decoder().feed(f'!{body}*{chk:02X}', 0.0)
    assert reasons and reasons[0].startswith('msg_type:'), reasons


def test_other_valid_types_are_skipped_not_refused():
    d = Decoder()
    line = _nmea({'type': 4, 'mmsi': 2320000, 'year': 2016, 'month': 1, 'day': 12, 'lat': 50.8, 'lon': -1.3})[0]
    assert d.feed(line, 0.0) == ([], []) and d.skipped[4] == 1 and not d.refused


def test_fragment_buffer_is_bounded_and_times_out():
    d = Decoder(max_pending=4, fragment_timeout=1.0)
    for k in range(10):      # first parts whose second parts never come, on distinct sequence ids/channels
        d.feed(_nmea({'type': 5, 'mmsi': 235000000 + k, 'shipname': 'X'}, seq_id=k % 10, channel='AB'[k % 2])[0], 0.0)
    assert len(d.pending) == 4 and d.dropped_fragments == 6
    d.feed(_nmea(POS)[0], 2.0)
    assert not d.pending and d.dropped_fragments == 10


def test_a_synthetic_day_at_a_busy_port_keeps_memory_bounded():
    """24 h of traffic at 10 sentences/s (864,000 lines; a busy port: Rotterdam's receivers hear ~10–30/s):

    4,000 MMSIs over the day, each present a few hours; 2 % of the lines are two-part static data,
    0.2 % of those lose their second part, 0.1 % of the lines are corrupt. The decoder's pending
    fragments and the ship table stay within their bounds every hour; throughput is measured."""
    rng = np.random.default_rng(7)
    n_ships, rate, hours = 4000, 10.0, 24
    positions = [_nmea({**POS, 'mmsi': 230000000 + k, 'lat': 50.8 + 0.1 * rng.normal(),
                        'lon': -1.2 + 0.1 * rng.normal()})[0].encode() for k in range(n_ships)]
    statics = [[s.encode() for s in _nmea({'type': 5, 'mmsi': 230000000 + k, 'shipname': f'SHIP {k}',
                                           'ship_type': 70}, seq_id=k % 10)] for k in range(0, n_ships, 10)]
    corrupt = _flip_checksum(_nmea(POS)[0]).encode()
    d = Decoder(max_pending=64, fragment_timeout=5.0)
    table = ShipTable(max_ships=1000, forget_after=1800.0)
    per_hour = int(rate * 3600)
    start = time.perf_counter()
    reports = 0
    for h in range(hours):
        # ships present this hour: a window sliding over the MMSIs (turnover through the day)
        lo = int(h / hours * (n_ships - 600))
        who = rng.integers(lo, lo + 600, per_hour)
        kind = rng.random(per_hour)
        for i in range(per_hour):
            now = h * 3600 + i / rate
            if kind[i] < 0.001:
                line = corrupt
            elif kind[i] < 0.021:
                parts = statics[int(who[i]) // 10 % len(statics)]
                d.feed(parts[0], now)
                line = parts[1] if kind[i] > 0.00104 else None        # ~0.2 % lose their second part
                if line is None:
                    continue
            else:
                line = positions[who[i]]
            out, _ = d.feed(line, now)
            for r in out:
                if isinstance(r, Position) and position_problem(r.fields) is None:
                    table.position(r.fields.mmsi, now, now)
                    reports += 1
                elif isinstance(r, Static):
                    table.static(r.mmsi, now, r.name, r.ship_type, r.callsign)
        table.expire((h + 1) * 3600)
        assert len(d.pending) <= 64 and len(table) <= 1000, (h, len(d.pending), len(table))
        assert len(d.refused) <= 3 and len(d.skipped) == 0
    elapsed = time.perf_counter() - start
    assert d.sentences > hours * per_hour and reports > 0.95 * hours * per_hour
    assert d.refused['checksum'] > 0 and d.dropped_fragments > 0 and table.forgotten > 0
    print(f'synthetic day: {d.sentences} lines, {reports} positions, {d.dropped_fragments} fragments dropped, '
          f'{table.forgotten} ships forgotten, {elapsed:.1f} s ({d.sentences / elapsed:,.0f} lines/s)')
