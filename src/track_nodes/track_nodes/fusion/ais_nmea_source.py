"""``ais_nmea_source``: live AIS from NMEA 0183 sentences (UDP or a file) as tracks in ``map``, one per MMSI.

Input: a UDP socket on ``udp_address``:``udp_port`` (0: none; 10110 the usual NMEA port) and/or a
``file`` read ``file_lines`` lines per ``poll``; tag blocks and receiver times allowed
(``track_nodes.fusion.nmea``: pyais, multi-part assembly bounded by ``max_pending`` and
``fragment_timeout``). Read without blocking on a steady timer every ``poll`` s (``max_datagrams``).

Output: each position report (types 1, 2, 3, 18, 19) alone in a TrackArray on ``ais/nmea/tracks``
(``prefix``): id = MMSI, position in ``map`` through the run's datum, σ 5 m (high accuracy) or 15 m,
velocity from SOG/COG or not estimated (``track_core.ais.live``); stamp ``arrival`` (default) or
``receiver``; ``own_ship:=false`` drops ``!AIVDO``. Static data (types 5, 19, 24) go to the latched
``ais/nmea/ships`` (DiagnosticArray, at most every ``ships_period`` s).

Datum (``track_core.ais.datum``, ``track_nodes.fusion.map_datum``): ``origin`` [lat, lon] or
``[0.0]``: the latched ``map_datum`` heard within ``datum_wait`` s, else the first fix, then
published (NavSatFix) and as ``earth`` → ``map`` on ``/tf_static``. Datums differing by > 1 cm
conflict: every report refused, naming both.

Refused (``TrackNode.refuse`` under ``<prefix>/udp`` or ``<prefix>/file``): bad checksum, truncated
or malformed sentences, unknown types, out-of-range fields, an MMSI's older report, any report under
a datum conflict; other valid types are counted. Silence for ``silence`` s is reported once and on
resuming. Memory bounded: the fragment buffer, ``max_ships`` (least recently heard forgotten first),
``forget_after``. In full: docs/MODULES.md, "The ais_nmea_source node in full".
"""

from __future__ import annotations

import errno
import math
import socket
from dataclasses import dataclass
from pathlib import Path

from diagnostic_msgs.msg import DiagnosticArray

from track_core.ais.datum import Datum
from track_core.ais.live import FeedWatch, ShipTable, position_problem, state_report
from track_msgs.msg import TrackArray
from track_msgs_py.ais import report_to_array, ships_to_diagnostics
from track_msgs_py.diagnostics import DIAG_OK, DIAG_WARN, diagnostic_array, diagnostic_status
from track_msgs_py.qos import ESTIMATE_QOS, STATIC_QOS
from track_msgs_py.topics import AIS_NMEA, DIAGNOSTICS
from track_nodes.base import ParameterError, TrackNode, param
from track_nodes.fusion.map_datum import MapDatumLink, latlon_param
from track_nodes.fusion.nmea import Decoder, Position, Static

MAX_DATAGRAM = 65535


@dataclass
class AisNmeaSourceParams:
    """Parameters of ``ais_nmea_source``."""

    udp_address: str = param('127.0.0.1', 'address the UDP socket binds to (0.0.0.0: every interface)')
    udp_port: int = param(10110, 'UDP port of the NMEA feed (0: no UDP)', 0, 65535)
    file: str = param('', 'a file of NMEA sentences to read (empty: none)')
    file_lines: int = param(200, 'lines of the file read per poll', 1, 1_000_000)
    poll: float = param(0.02, 'period of the reading timer (steady clock) [s]', 1e-3, 10.0)
    max_datagrams: int = param(1000, 'datagrams read at most per poll', 1, 1_000_000)
    stamp: str = param('arrival', 'arrival: stamp a report with the node clock when it arrives; receiver: with the '
                       'line\'s receiver time (tag block c:, a timestamp before or after the sentence), arrival '
                       'without one', choices=('arrival', 'receiver'))
    own_ship: bool = param(True, 'also publish the !AIVDO reports (the receiving ship itself)')
    origin: list[float] = param([0.0], 'map datum [lat, lon] in degrees; [0.0]: the one on map_datum, else the '
                                'first fix')
    prefix: str = param(AIS_NMEA, 'topic prefix: tracks on <prefix>/tracks, ships on <prefix>/ships')
    max_ships: int = param(10_000, 'MMSIs kept at most (the least recently heard forgotten first)', 1, 10_000_000)
    forget_after: float = param(3600.0, 'a ship silent this long is forgotten [s]', 1.0, 1e7)
    max_pending: int = param(256, 'multi-part messages awaiting their parts at most', 1, 1_000_000)
    fragment_timeout: float = param(5.0, 'a multi-part message not completed within this is dropped [s]',
                                    0.01, 3600.0)
    silence: float = param(30.0, 'the feed is reported stopped after this long without a line [s]', 0.1, 1e6)
    ships_period: float = param(1.0, 'the ships\' static data are republished at most this often [s]', 0.01, 3600.0)
    datum_wait: float = param(1.0, 'listen this long on map_datum before reading input or publishing a datum [s]',
                              0.0, 60.0)


class AisNmeaSourceNode(TrackNode):
    DEFAULT_NAME = 'ais_nmea_source'
    Params = AisNmeaSourceParams
    p: AisNmeaSourceParams  # the declared parameters (base/params.py)

    def setup(self) -> None:
        p = self.p
        if not p.udp_port and not p.file:
            raise ParameterError('parameters udp_port and file are both unset: no NMEA input')
        prefix = p.prefix.rstrip('/') or AIS_NMEA
        self.in_udp, self.in_file = f'{prefix}/udp', f'{prefix}/file'
        self.decoder = Decoder(max_pending=p.max_pending, fragment_timeout=p.fragment_timeout)
        self.ships = ShipTable(max_ships=p.max_ships, forget_after=p.forget_after)
        self.watch = FeedWatch(p.silence)
        self.published = 0
        self.map_datum = MapDatumLink(self, latlon_param('origin', p.origin, unset_allowed=True))
        self.ready = False
        self.pub = self.create_publisher(TrackArray, f'{prefix}/tracks', ESTIMATE_QOS)
        self.pub_ships = self.create_publisher(DiagnosticArray, f'{prefix}/ships', STATIC_QOS)
        self.pub_health = self.create_publisher(DiagnosticArray, DIAGNOSTICS, 10)
        self.sock = self._open_udp() if p.udp_port else None
        self.lines = self._open_file(p.file) if p.file else None
        self.started = self.steady_now()
        self._ships_dirty, self._ships_sent = False, -math.inf
        self.timer = self.create_timer(p.poll, self._poll, clock=self._steady)
        self.health_timer = self.create_timer(1.0, self._health, clock=self._steady)

    # -- inputs ------------------------------------------------------------------------------
    def _open_udp(self) -> socket.socket:
        p = self.p
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            sock.bind((p.udp_address, p.udp_port))
        except OSError as exc:
            sock.close()
            raise ParameterError(f'parameters udp_address={p.udp_address!r}, udp_port={p.udp_port}: cannot bind '
                                 f'({exc.strerror})') from None
        sock.setblocking(False)
        self.get_logger().info(f'reading NMEA from udp://{p.udp_address}:{sock.getsockname()[1]}')
        return sock

    def _open_file(self, path: str):
        try:
            f = Path(path).open('rb')  # noqa: SIM115 - read a batch per poll, closed at the end or in destroy_node
        except OSError as exc:
            raise ParameterError(f'parameter file={path!r}: {exc.strerror}') from None
        self.get_logger().info(f'reading NMEA from {path}')
        return f

    @property
    def datum(self) -> Datum | None:
        return self.map_datum.datum

    @property
    def conflict(self) -> str | None:
        return self.map_datum.conflict

    @property
    def udp_port(self) -> int:
        """The port the socket is bound to (a ``udp_port`` test may ask the system for a free one)."""
        return self.sock.getsockname()[1] if self.sock is not None else 0

    def _poll(self) -> None:
        now = self.steady_now()
        if not self.ready:   # first hear the run's datum, if there is one (a latched message takes a moment)
            if now - self.started < self.p.datum_wait:
                return
            self.ready = True
            self.map_datum.fix_own()
        if self.sock is not None:
            for _ in range(self.p.max_datagrams):
                try:
                    data = self.sock.recv(MAX_DATAGRAM)
                except BlockingIOError:
                    break
                except OSError as exc:
                    if exc.errno in (errno.EAGAIN, errno.EWOULDBLOCK):
                        break
                    self.get_logger().warning(f'udp: {exc}')
                    break
                for line in data.splitlines():
                    self._line(line, now, self.in_udp)
        if self.lines is not None:
            for _ in range(self.p.file_lines):
                line = self.lines.readline()
                if not line:
                    self.get_logger().info(f'end of {self.p.file}: {self.decoder.sentences} lines, '
                                           f'{self.published} reports published')
                    self.lines.close()
                    self.lines = None
                    break
                self._line(line, now, self.in_file)
        if self._ships_dirty and now - self._ships_sent >= self.p.ships_period:
            self._publish_ships(now)

    def _line(self, line: bytes, now: float, stream: str) -> None:
        if not line.strip():
            return
        back = self.watch.heard(now)
        if back:
            self.get_logger().info(f'{self.resolved(stream)}: the feed is back')
        reports, reasons = self.decoder.feed(line, now)
        for reason in reasons:
            self.refuse(stream, reason)
        for r in reports:
            if isinstance(r, Position):
                self._position(r, now, stream)
            elif isinstance(r, Static):
                _, changed = self.ships.static(r.mmsi, now, r.name, r.ship_type, r.callsign)
                self._ships_dirty |= changed

    def _stamp(self, r) -> float:
        if self.p.stamp == 'receiver' and r.t is not None:
            return r.t
        return self.get_clock().now().nanoseconds * 1e-9

    def _position(self, r: Position, now: float, stream: str) -> None:
        if r.own and not self.p.own_ship:
            return
        reason = position_problem(r.fields)
        t = self._stamp(r)
        if reason is None:
            reason = self.conflict or self.ships.order_problem(r.fields.mmsi, t)
        if reason is None and self.datum is None:   # the first fix sets the run's datum
            self.map_datum.fix(r.fields.lat, r.fields.lon)
        if reason is not None:
            self.refuse(stream, reason)
            return
        report = state_report(r.fields, t, self.datum)
        self.ships.position(r.fields.mmsi, t, now)
        self.pub.publish(report_to_array(t, report, self.get_name()))
        self.published += 1

    # -- outputs -----------------------------------------------------------------------------
    def _publish_ships(self, now: float) -> None:
        self._ships_dirty, self._ships_sent = False, now
        ships = [s for s in self.ships.ships.values() if s.name or s.ship_type or s.callsign]
        self.pub_ships.publish(ships_to_diagnostics(self.get_clock().now().nanoseconds * 1e-9, ships))

    def _health(self) -> None:
        """Feed silence (reported once per silence) and expiry of silent ships."""
        now = self.steady_now()
        self.ships.expire(now)
        quiet = self.watch.check(now, self.started)
        if quiet is not None:
            self.get_logger().warning(f'NMEA feed silent for {quiet:.0f} s (no line on '
                                      f'{"udp" if self.sock is not None else "file"})')
        if self.watch.quiet or quiet is not None:
            level, text = DIAG_WARN, 'NMEA feed silent'
        else:
            level, text = DIAG_OK, 'NMEA feed live'
        d = self.decoder
        status = diagnostic_status(f'{self.get_fully_qualified_name()}/feed', level, text, {
            'lines': d.sentences, 'published': self.published, 'refused': sum(d.refused.values()),
            'skipped': sum(d.skipped.values()), 'dropped_fragments': d.dropped_fragments,
            'pending_fragments': len(d.pending), 'ships': len(self.ships), 'forgotten': self.ships.forgotten,
            'datum': self.datum.describe() if self.datum else 'none'})
        self.pub_health.publish(diagnostic_array(self.get_clock().now().nanoseconds * 1e-9, [status]))

    def destroy_node(self) -> None:
        if getattr(self, 'sock', None) is not None:
            self.sock.close()
            self.sock = None
        if getattr(self, 'lines', None) is not None:
            self.lines.close()
            self.lines = None
        super().destroy_node()
