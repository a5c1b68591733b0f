"""Play an NMEA 0183 AIS capture over UDP at its own pace: the receiver a capture file stands in for.

One sentence per datagram when its time comes, as receivers do (``nc -u HOST PORT < capture.nmea``
sends the whole file at once).

Pacing: a line's time is its receiver time (``track_nodes.fusion.nmea.split_line``: tag block
``c:``, or a timestamp before the sentence or after its checksum); the first timed line goes at
once, a line of time t (t − t_first) / ``rate`` s later (gaps cut to ``max_gap``); an untimed line
goes with the one before it, a capture without times at ``untimed_rate`` lines a second. Lines that
are no sentence are sent anyway (the source refuses and counts them). ``restamp`` (the node's
default, ``--restamp``): each line gets a fresh tag block ``c:`` (ms) of the time it is played, so
``ais_nmea_source`` with ``stamp:=receiver`` keeps the capture's spacing on the run's clock.

- ``track-nmea-play FILE --port N --rate R`` (wall clock, no ROS: ``main``);
  ``track-nmea-play --write-capture OUT [--csv FILE] [--duration S]`` writes a capture of an AIS
  CSV (default: the Solent file) with pyais's encoder: per report one ``!AIVDM`` type 1 (class A)
  or 18 (class B) sentence with tag block (``s:`` the CSV's name, ``c:`` UTC ms), accuracy high,
  SOG/COG from the file, and one type 5 per ship before its first report (``SHIP <mmsi>``);
- the node ``nmea_player`` (``fusion.nmea_player``), paced by the node clock (the ``ais_live``
  scenario), ``start`` and origin as ``ais_source``'s: data time τ plays at origin + τ − start.
"""

from __future__ import annotations

import argparse
import math
import socket
import sys
import time
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

from pyais import TagBlock
from pyais.encode import encode_dict

from track_nodes.fusion.nmea import MS_THRESHOLD, split_line

DEFAULT_PORT = 10110
MAX_GAP = 60.0          # a longer gap between receiver times is cut to this [s of capture time]
UNTIMED_RATE = 50.0     # lines a second of a capture without receiver times


# -- a capture's lines and their times -------------------------------------------------------------
def timed_lines(lines: Iterable[bytes], max_gap: float = MAX_GAP) -> Iterator[tuple[float | None, bytes]]:
    """(play time [s of capture time from the first timed line, gaps cut to ``max_gap``] or None, line).

    None: no line so far had a time (an untimed capture, or its untimed head). A line without a
    time of its own gets the time of the line before it. Streams: a day's capture is never held whole.
    """
    first = last_t = None
    clock = 0.0
    for raw in lines:
        line = raw.rstrip(b'\r\n')
        if not line.strip():
            continue
        t, _, _ = split_line(line)
        if t is not None and math.isfinite(t):
            if first is None:
                first = last_t = t
            clock += min(max(t - last_t, 0.0), max_gap)   # a time going back plays at once
            last_t = t
        yield (None if first is None else clock), line


def restamped(line: bytes, t: float, source: str = '') -> bytes:
    """``line``'s sentence with a fresh tag block: ``c:`` = ``t`` [s UNIX] in ms (``s:`` the source when given)."""
    _, sentence, reason = split_line(line)
    if reason is not None:
        return line   # not a sentence: sent as it is (the source refuses it)
    tag = TagBlock.create(receiver_timestamp=_c_value(t), source_station=source or None)
    return b'\\' + tag + b'\\' + sentence


def _c_value(t: float) -> str:
    """A tag block ``c:``: milliseconds, as many receivers write it; a clock before 1973 (a sim clock from 0),
    whose milliseconds readers take for seconds (``nmea.MS_THRESHOLD``), as seconds with 3 decimals."""
    return str(round(t * 1000.0)) if t * 1000.0 > MS_THRESHOLD else f'{t:.3f}'



# -- a capture written from a CSV of AIS reports ------------------------------------------------
def capture_from_csv(csv: str | None = None, start: float = 0.0, duration: float = math.inf,
                     columns: str | None = None) -> Iterator[str]:
    """Lines of an NMEA capture of the AIS reports of ``csv`` (``track_core.ais.read_ais``; module docstring)."""
    from track_core.ais import read_ais

    data = read_ais(csv, columns=columns)
    source = (data.path.stem if data.path is not None else 'csv')[:15].replace(',', '_').replace('*', '_')
    named: set[int] = set()
    seq = 0
    for k in range(data.t.size):
        if not start <= data.t[k] <= start + duration:
            continue
        mmsi = int(data.mmsi[k])
        tag = '\\' + TagBlock.create_str(source_station=source, receiver_timestamp=_c_value(data.t0 + data.t[k]))
        if mmsi not in named:
            named.add(mmsi)
            seq = seq % 9 + 1
            for s in encode_dict({'msg_type': 5, 'mmsi': mmsi, 'shipname': f'SHIP {mmsi}', 'ship_type': 70},
                                 talker_id='AI', sentence_type='VDM', seq_id=seq):
                yield tag + '\\' + s
        sog, cog = float(data.sog[k]), float(data.cog[k])
        fields = {'msg_type': 1 if mmsi % 4 else 18, 'mmsi': mmsi, 'lat': float(data.lat[k]),
                  'lon': float(data.lon[k]), 'accuracy': 1, 'heading': 511,
                  'speed': sog if math.isfinite(sog) and 0 <= sog < 102.3 else 102.3,
                  'course': cog % 360.0 if math.isfinite(cog) else 360.0}
        for s in encode_dict(fields, talker_id='AI', sentence_type='VDM'):
            yield tag + '\\' + s


# -- the wall-clock tool ---------------------------------------------------------------------------
@dataclass
class PlayStats:
    lines: int = 0
    timed: int = 0
    seconds: float = 0.0


def play(lines: Iterable[bytes], send, rate: float = 1.0, *, max_gap: float = MAX_GAP,
         untimed_rate: float = UNTIMED_RATE, restamp: bool = False, clock=time.monotonic,
         wall=time.time, sleep=time.sleep) -> PlayStats:
    """Send each line (``send(bytes)``) at its time / ``rate`` after the first (module docstring)."""
    stats = PlayStats()
    t0 = clock()
    untimed = 0
    for t, line in timed_lines(lines, max_gap):
        if t is None:
            untimed += 1
            due = t0 + untimed / untimed_rate
        else:
            due = t0 + t / rate if rate > 0 else clock()
        wait = due - clock()
        if wait > 0:
            sleep(wait)
        send(restamped(line, wall()) if restamp else line)
        stats.lines += 1
        stats.timed += t is not None
    stats.seconds = clock() - t0
    return stats


def _parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog='track-nmea-play', description=__doc__.split('\n\n')[0])
    ap.add_argument('file', nargs='?', help='the capture: NMEA lines, with or without tag blocks or timestamps')
    ap.add_argument('--host', default='127.0.0.1', help='where to send (default 127.0.0.1)')
    ap.add_argument('--port', type=int, default=DEFAULT_PORT, help=f'UDP port (default {DEFAULT_PORT})')
    ap.add_argument('--rate', type=float, default=1.0, help='x the capture\'s pace (default 1; 0: as fast as possible)')
    ap.add_argument('--max-gap', type=float, default=MAX_GAP, help=f'cut longer gaps to this [s] (default {MAX_GAP:g})')
    ap.add_argument('--untimed-rate', type=float, default=UNTIMED_RATE,
                    help=f'lines a second when the capture has no times (default {UNTIMED_RATE:g})')
    ap.add_argument('--restamp', action='store_true', help='send each line with a tag block c: of the time it is '
                    'sent (ais_nmea_source stamp:=receiver keeps the capture\'s spacing exactly)')
    ap.add_argument('--write-capture', metavar='OUT', help='write a capture of an AIS CSV to OUT and exit')
    ap.add_argument('--csv', help='the AIS CSV for --write-capture (default: the Solent file of the shared data)')
    ap.add_argument('--start', type=float, default=0.0, help='--write-capture: from this [s after the first report]')
    ap.add_argument('--duration', type=float, default=math.inf, help='--write-capture: this long [s]')
    return ap


def _write_capture(args) -> int:
    try:
        with Path(args.write_capture).open('w') as out:
            n = sum(out.write(line + '\n') > 0 for line in capture_from_csv(args.csv, args.start, args.duration))
    except (OSError, ValueError) as exc:
        print(f'track-nmea-play: {exc}', file=sys.stderr)
        return 2
    print(f'track-nmea-play: {n} lines written to {args.write_capture}')
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """``track-nmea-play``: one line on a bad argument or file, a summary at the end; Ctrl-C/SIGTERM stop it."""
    from track_nodes.base.signals import STOP_SIGNALS, stop_on

    args = _parser().parse_args(argv)
    if args.write_capture:
        return _write_capture(args)
    if not args.file:
        print('track-nmea-play: a capture FILE is needed (or --write-capture OUT)', file=sys.stderr)
        return 2
    if not (0 < args.port < 65536) or not (args.rate >= 0 and math.isfinite(args.rate)) or not args.max_gap > 0 \
            or not args.untimed_rate > 0:
        print(f'track-nmea-play: need 0 < --port < 65536 (got {args.port}), --rate >= 0 (got {args.rate}), '
              f'--max-gap > 0 and --untimed-rate > 0', file=sys.stderr)
        return 2
    try:
        f = Path(args.file).open('rb')  # noqa: SIM115 - closed below, also on a stop
    except OSError as exc:
        print(f'track-nmea-play: {args.file}: {exc.strerror}', file=sys.stderr)
        return 2
    stop_on(*STOP_SIGNALS)
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    target = (args.host, args.port)
    stats = PlayStats()
    try:
        stats = play(f, lambda line: sock.sendto(line + b'\r\n', target), args.rate, max_gap=args.max_gap,
                     untimed_rate=args.untimed_rate, restamp=args.restamp)
    except KeyboardInterrupt:
        print('track-nmea-play: stopped', file=sys.stderr)
    except OSError as exc:
        print(f'track-nmea-play: udp://{args.host}:{args.port}: {exc.strerror or exc}', file=sys.stderr)
        return 1
    finally:
        sock.close()
        f.close()
    print(f'track-nmea-play: {stats.lines} lines ({stats.timed} timed) to udp://{args.host}:{args.port} '
          f'in {stats.seconds:.1f} s')
    return 0


if __name__ == '__main__':
    sys.exit(main())
