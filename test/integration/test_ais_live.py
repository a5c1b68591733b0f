"""The ais_live scenario: a capture played over UDP into the live AIS source and the fusion beside the radar.

The launcher runs config/ais_live.yaml (a minute of the Solent AIS file encoded as NMEA, played by
nmea_player on /clock into ais_nmea_source, the simulated radar on the same ships, the fusion node) and
prints the summary: one live track per MMSI, and the radar tracks associated with the right MMSI.
"""

from __future__ import annotations

import re
import socket
import subprocess
import sys

import pytest

from track_core.ais import default_path
from track_nodes.bag.frames import check_frames
from track_nodes.report.read import read_topics

pytestmark = pytest.mark.skipif(not default_path().is_file(), reason='shared AIS data not found')


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(('127.0.0.1', 0))
        return s.getsockname()[1]


def test_a_capture_played_into_the_live_source_is_fused_with_the_radar(tmp_path, env_factory, repo):
    port = _free_port()
    params = tmp_path / 'port.yaml'
    params.write_text(f'/**/nmea_player:\n  ros__parameters:\n    port: {port}\n'
                      f'/**/ais_nmea_source:\n  ros__parameters:\n    udp_port: {port}\n')
    cmd = [sys.executable, '-m', 'track_nodes.launch', str(repo / 'config/ais_live.yaml'), '--record', 'live',
           '--duration', '60', '--params', str(params)]
    proc = subprocess.run(cmd, cwd=tmp_path, env=env_factory(), capture_output=True, text=True, timeout=240)
    assert proc.returncode == 0, proc.stderr[-3000:]
    out = proc.stdout
    print(out)
    live = re.search(r'/ais/nmea/tracks: (\d+) tracks, one per MMSI; (\d+) reports', out)
    assert live and int(live[1]) >= 30 and int(live[2]) > int(live[1]), out
    one = re.search(r'one-to-one +precision ([\d.]+) +recall ([\d.]+)', out)
    assert one and float(one[1]) >= 0.9 and float(one[2]) >= 0.9, out
    bag = tmp_path / 'bags/live'
    datum = read_topics(bag, {'/map_datum'})['/map_datum']
    assert len(datum) == 1 and (datum[0].latitude, datum[0].longitude) == (50.79476, -1.11141166666667)
    assert check_frames(bag) == []                   # every frame placed: map under earth on /tf_static
