"""``nmea_player``: an NMEA AIS capture played over UDP on the node clock, the stand-in for an AIS receiver.

The capture's lines and their pacing are ``fusion.nmea_play`` (``timed_lines``, ``restamped``,
``capture_from_csv``; its docstring says how a line's time is read and how the play is paced). Under the
launcher the node clock is ``/clock``: the ``ais_live`` scenario plays the capture in step with the
simulated radar; its ``start`` and origin follow ``ais_source``'s, so a report of data time τ is played
at origin + τ − start.
"""

from __future__ import annotations

import socket
from dataclasses import dataclass
from pathlib import Path

from track_nodes.base import FixedRateSteps, ParameterError, TrackNode, param
from track_nodes.fusion.nmea_play import DEFAULT_PORT, MAX_GAP, capture_from_csv, restamped, timed_lines


@dataclass
class NmeaPlayerParams:
    """Parameters of ``nmea_player``."""

    file: str = param('', 'the capture to play (empty: the AIS CSV csv encoded as a capture at start)')
    csv: str = param('', 'file empty: the AIS CSV to encode (empty: the Solent file of the shared data)')
    host: str = param('127.0.0.1', 'where the datagrams go')
    port: int = param(DEFAULT_PORT, 'UDP port of the live AIS source', 1, 65535)
    start: float = param(0.0, 'capture time played at node time 0 [s after the first timed line]', 0.0, 1e7)
    duration: float = param(600.0, 'length of the played window [s of capture time]', 1.0, 1e7)
    tick: float = param(0.1, 'sending timer period [s of node time]: a line goes at the first tick at or after '
                        'its time', 1e-3, 60.0)
    max_gap: float = param(MAX_GAP, 'a longer gap between receiver times is cut to this [s]', 1e-3, 1e6)
    restamp: bool = param(True, 'send each line with a tag block c: of its play time on the node clock')


class NmeaPlayerNode(TrackNode):
    """A capture played over UDP on the node clock (module docstring): the stand-in for an AIS receiver."""

    DEFAULT_NAME = 'nmea_player'
    Params = NmeaPlayerParams
    p: NmeaPlayerParams  # the declared parameters (base/params.py)

    def setup(self) -> None:
        p = self.p
        if p.file:
            try:
                with Path(p.file).open('rb') as f:
                    lines = list(timed_lines(f, p.max_gap))
            except OSError as exc:
                raise ParameterError(f'parameter file={p.file!r}: {exc.strerror}') from None
            what = p.file
        else:
            try:
                text = list(capture_from_csv(p.csv or None, 0.0, p.start + p.duration))
            except (OSError, ValueError) as exc:
                raise ParameterError(f'parameter csv={p.csv!r}: {exc}') from None
            lines = list(timed_lines((s.encode() for s in text), p.max_gap))
            what = f'{p.csv or "the Solent AIS file"} (encoded as NMEA)'
        # the played window; untimed lines (none in a restamped capture) go at its start
        self.lines = [(t or 0.0, line) for t, line in lines if p.start <= (t or 0.0) <= p.start + p.duration]
        self.next = 0
        self.sent = 0
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.target = (p.host, p.port)
        self.get_logger().info(f'{len(self.lines)} lines of {what} to udp://{p.host}:{p.port}')
        self.steps = FixedRateSteps(self, p.tick, self._step, max_time=p.duration + p.tick)

    def _step(self, t: float) -> None:
        origin = self.steps.origin or 0.0
        lines, k = self.lines, self.next
        while k < len(lines) and origin + lines[k][0] - self.p.start <= t + 1e-9:
            play_t = origin + lines[k][0] - self.p.start
            data = restamped(lines[k][1], play_t) if self.p.restamp else lines[k][1]
            try:
                self.sock.sendto(data + b'\r\n', self.target)
                self.sent += 1
            except OSError as exc:   # nobody listening is no error for UDP; a bad address is, once per tick
                self.get_logger().warning(f'udp://{self.target[0]}:{self.target[1]}: {exc.strerror or exc}')
                break
            k += 1
        self.next = k
        if k == len(lines) and lines and self.sent == k:
            self.get_logger().info(f'capture played: {self.sent} lines', once=True)

    def destroy_node(self) -> None:
        if getattr(self, 'sock', None) is not None:
            self.sock.close()
            self.sock = None
        super().destroy_node()
