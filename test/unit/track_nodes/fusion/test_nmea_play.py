"""Playing an NMEA capture: receiver times → pace, restamped tag blocks, a capture written from an AIS CSV."""

import numpy as np
import pytest
from pyais.encode import encode_dict

from track_core.ais import default_path, read_ais
from track_nodes.fusion.nmea import Decoder, Position, Static, split_line
from track_nodes.fusion.nmea_play import capture_from_csv, main, play, restamped, timed_lines

S = encode_dict({'msg_type': 1, 'mmsi': 235000001, 'lat': 50.8, 'lon': -1.3, 'speed': 8.0, 'course': 30.0},
                talker_id='AI', sentence_type='VDM')[0]


def test_lines_are_timed_by_their_receiver_times_with_gaps_cut():
    lines = [S, f'1452603731 {S}', f'\\c:1452603733500*{0:02X}\\{S}', S, f'{S},1452603800', f'{S},1452603700',
             'garbage']
    lines[2] = restamped(S.encode(), 1452603733.5).decode()     # a tag block with a valid checksum
    got = list(timed_lines([x.encode() for x in lines], max_gap=10.0))
    assert [t for t, _ in got] == [None, 0.0, 2.5, 2.5, 12.5, 12.5, 12.5]   # 66.5 s cut to 10; back in time: at once
    assert got[-1][1] == b'garbage'                                          # sent anyway: the source refuses it


def test_a_restamped_line_keeps_its_sentence():
    for line in (S, f'2016-01-12T13:02:11Z {S}', f'{S},1452603731'):
        out = restamped(line.encode(), 1796543682.125, 'rx1')
        t, sentence, reason = split_line(out)
        assert reason is None and sentence == S.encode() and t == pytest.approx(1796543682.125, abs=1e-3)
    t, _, _ = split_line(restamped(S.encode(), 12.25))                     # a sim clock from 0: seconds, not ms
    assert t == pytest.approx(12.25)
    assert restamped(b'no sentence', 5.0) == b'no sentence'


class FakeClock:
    def __init__(self):
        self.now = 100.0

    def __call__(self):
        return self.now

    def sleep(self, dt):
        assert dt > 0
        self.now += dt


def test_play_sends_each_line_at_its_time_over_the_rate():
    clock, sent = FakeClock(), []
    lines = [f'{1000 + t} {S}'.encode() for t in (0.0, 1.0, 1.0, 5.0)]
    stats = play(lines, lambda line: sent.append((clock.now, line)), rate=2.0, clock=clock, sleep=clock.sleep,
                 wall=lambda: 7.0, restamp=True)
    assert [round(t - 100.0, 9) for t, _ in sent] == [0.0, 0.5, 0.5, 2.5]
    assert (stats.lines, stats.timed) == (4, 4)
    assert all(split_line(line)[0] == pytest.approx(7.0) for _, line in sent)   # restamped with the wall clock
    clock, sent = FakeClock(), []
    play([S.encode()] * 3, lambda line: sent.append(clock.now), clock=clock, sleep=clock.sleep, untimed_rate=10.0)
    assert np.allclose(np.array(sent) - 100.0, [0.1, 0.2, 0.3])             # no times: untimed_rate lines a second


@pytest.mark.skipif(not default_path().is_file(), reason='shared AIS data not found')
def test_a_capture_written_from_the_solent_csv_decodes_to_its_reports():
    data = read_ais(None)
    lines = list(capture_from_csv(None, 0.0, 120.0))
    keep = (data.t >= 0.0) & (data.t <= 120.0)
    d = Decoder()
    positions, statics = [], []
    for k, line in enumerate(lines):
        reports, reasons = d.feed(line, float(k))
        assert not reasons, reasons
        positions += [r for r in reports if isinstance(r, Position)]
        statics += [r for r in reports if isinstance(r, Static)]
    assert len(positions) == keep.sum() and {s.mmsi for s in statics} == set(data.mmsi[keep].tolist())
    lat = np.array([p.fields.lat for p in positions])
    t = np.array([p.t for p in positions])
    np.testing.assert_allclose(lat, data.lat[keep], atol=2e-6)                # 1/10 000 minute
    np.testing.assert_allclose(t, data.t0 + data.t[keep], atol=1e-3)         # receiver times in ms
    assert statics[0].name.startswith('SHIP ')


def test_the_tool_refuses_a_bad_file_or_port_in_one_line(capsys, tmp_path):
    assert main([str(tmp_path / 'missing.nmea')]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and 'missing.nmea' in err[0]
    assert main([str(tmp_path), '--port', '70000']) == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1
    assert main(['--write-capture', str(tmp_path / 'x.nmea'), '--csv', str(tmp_path / 'none.csv')]) == 2
