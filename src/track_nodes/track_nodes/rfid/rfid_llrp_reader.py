"""``rfid_llrp_reader``: a real UHF reader (LLRP: Impinj Speedway/R700, Zebra FX) in place of ``rfid_reader``.

The reader side of the step-by-step protocol for a person holding a real reader: it connects to
the reader at ``host``:``port`` over LLRP (``track_nodes.rfid.llrp``, sllurp), configures antennas,
transmit power and the Impinj phase-angle and RSSI reports, and performs each command of
``/rfid/command`` with the reads it gets (``track_core.rfid.live``): a MOVE is the reads that arrive
taken in the ``move_s`` after the command (the time the user takes for one step; the answer comes
with the first read taken after it, or ``latency_s`` later when the tag is no longer read), processed into dφ by
the real-reader signal processing (``relock_reads``, ``noise``) with this reader's sign, wrap and
hop table (``channels_mhz``: LLRP ChannelIndex → carrier); a TURN is taken as made as asked, checked
by the reads of ``turn_read_s`` after it. Published as ``rfid_reader`` does
(``track_nodes.rfid.reads``): ``/rfid/phase`` per MOVE and ``/rfid/step`` last; there is no truth, so
no ``/rfid/user/pose`` and no ``/rfid/user/status``. One answer per command ``seq``
(``track_core.rfid.delivery.AnswerCache``), as ``rfid_reader``.

The tag is ``epc``, or when empty the first tag read (logged); reads of other tags are counted.
When the reader goes away, the node keeps running and reconnects every ``retry_s``; a MOVE it
misses comes back "signal lost" and the guidance repeats it. "Connected" is logged only when the
reader has answered in LLRP (its capabilities or its first report); a port that accepts the TCP
connection and stays silent for ``handshake_s`` is refused with one warning line and retried.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from track_core.rfid.delivery import AnswerCache, Verdict
from track_core.rfid.live import LiveActions, LiveAnswer, channel_carriers
from track_core.rfid.protocol import CommandKind
from track_core.rfid.signal import PhaseProcessor, UnwrapConfig
from track_core.rfid.world import WorldParams
from track_msgs.msg import RfidCommand as RfidCommandMsg
from track_msgs_py.qos import ESTIMATE_QOS
from track_msgs_py.records import RecordError
from track_msgs_py.records.rfid import RfidStep, read_command
from track_msgs_py.topics import RFID_COMMAND
from track_nodes.base import ParameterError, TrackNode, param
from track_nodes.rfid.llrp import DEFAULT_PORT, LlrpLink, reader_config
from track_nodes.rfid.params import PhaseParams, phase_model
from track_nodes.rfid.reads import ReaderTopics

_W = WorldParams()
FCC_CHANNELS_MHZ = [902.75 + 0.5 * i for i in range(50)]   # the FCC hop table (ChannelIndex 1..50)


@dataclass
class RfidLlrpReaderParams(PhaseParams):
    """Parameters of ``rfid_llrp_reader``."""

    host: str = param('', 'the reader\'s host name or address (required)')
    port: int = param(DEFAULT_PORT, 'the reader\'s LLRP port', 1, 65535)
    antennas: list[int] = param([1], 'antenna ports to inventory (1-based)')
    tx_power_dbm: float = param(0.0, 'transmit power [dBm]; 0 = the reader\'s maximum', 0.0, 40.0)
    epc: str = param('', 'the tag to follow (hex EPC); empty: the first tag read')
    channels_mhz: list[float] = param(FCC_CHANNELS_MHZ, 'the reader\'s hop table: carrier of ChannelIndex 1, 2, ... '
                                      '[MHz]')
    wrap: str = param('2pi', 'wrap period P of the reported phase: (0, π] or (0, 2π] (LLRP/Impinj)',
                      choices=('pi', '2pi'))
    convention: str = param('llrp', 'phase sign: llrp (rises with distance, LLRP/Impinj) or paper (eq. 3)',
                            choices=('paper', 'llrp'))
    move_s: float = param(_W.s_step / _W.walk_speed, 'how long the user takes for one MOVE: its reads [s]',
                          1e-2, 60.0, live=True)
    turn_read_s: float = param(_W.turn_read_s, 'reads collected after a TURN to check the signal [s]', 0.0, 60.0,
                               live=True)
    latency_s: float = param(1.0, 'how long to wait after an action for its reads still on their way when no '
                             'later read has come (the tag not read) [s]', 0.0, 10.0, live=True)
    relock_reads: int = param(5, 'signal processing: agreeing reads that re-lock after a phase step; 0 = never',
                              0, 1000)
    noise: str = param('robust', 'signal processing: robust (heavy-tailed noise learnt from the data), online '
                       '(Gaussian noise from the data) or fixed (the paper)', choices=('fixed', 'online', 'robust'))
    retry_s: float = param(2.0, 'seconds between connection attempts while the reader is away', 0.05, 3600.0)
    handshake_s: float = param(5.0, 'how long an accepted TCP connection may stay silent before it is refused as '
                               'no LLRP reader (the reader\'s capabilities or first report end the wait) [s]',
                               0.1, 600.0)
    tick: float = param(0.02, 'period of the timer that takes reads and publishes due answers [s]', 1e-3, 1.0)


class RfidLlrpReaderNode(TrackNode):
    DEFAULT_NAME = 'rfid_llrp_reader'
    Params = RfidLlrpReaderParams
    p: RfidLlrpReaderParams

    def validate_params(self, p: RfidLlrpReaderParams) -> None:
        if not p.host:
            raise ParameterError('parameter host is empty: allowed the reader\'s host name or address')
        if not p.antennas or any(a < 1 for a in p.antennas):
            raise ParameterError(f'parameter antennas={list(p.antennas)!r} is invalid: allowed antenna ports >= 1')
        if not p.channels_mhz or not all(865.0 <= f <= 928.0 for f in p.channels_mhz):
            raise ParameterError('parameter channels_mhz is invalid: allowed carriers in [865, 928] MHz')
        if p.epc and not (len(p.epc) % 4 == 0 and all(c in '0123456789abcdefABCDEF' for c in p.epc)):
            raise ParameterError(f'parameter epc={p.epc!r} is invalid: allowed hex digits, a multiple of 4')

    def setup(self) -> None:
        p = self.p
        self.validate_params(p)
        try:
            phase = phase_model(p)
            unwrap = UnwrapConfig.real_reader(phase, relock_reads=p.relock_reads, noise=p.noise)
        except ValueError as exc:
            raise ParameterError(f'invalid phase parameters: {exc}') from None
        self.live = LiveActions(PhaseProcessor(unwrap), p.move_s, p.turn_read_s, p.latency_s)
        self.table_hz = tuple(1e6 * f for f in p.channels_mhz)
        self.epc = p.epc.upper()
        self.other_reads = self.off_table_reads = 0
        self.cache: AnswerCache[tuple[LiveAnswer, float]] = AnswerCache()
        self.topics = ReaderTopics(self, phase.carrier_hz)
        self.sub_cmd = self.create_subscription(RfidCommandMsg, RFID_COMMAND, self._on_command, ESTIMATE_QOS)
        self.link = LlrpLink(p.host, p.port, reader_config(list(p.antennas), p.tx_power_dbm), p.retry_s,
                             log=self.get_logger().info, handshake_s=p.handshake_s,
                             warn=self.get_logger().warning)
        self.timer = self.create_timer(p.tick, self._tick)

    def apply_params(self, changed: set[str]) -> None:
        live, p = self.live, self.p       # in effect from the next command
        live.move_s, live.turn_read_s, live.latency_s = p.move_s, p.turn_read_s, p.latency_s

    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def _on_command(self, msg: RfidCommandMsg) -> None:
        try:
            cmd = read_command(msg)
        except RecordError as exc:
            self.cache.reject()
            self.refuse(RFID_COMMAND, f'command: {exc}')
            return
        verdict = self.cache.on_command(cmd.seq)
        if verdict is Verdict.REPLAY:  # the guidance has not seen the answer: send it again, nothing re-done
            answer, t = self.cache.answer
            self.topics.step.publish(RfidStep.from_result(answer.result, answer.duration).to_msg(t))
        elif verdict is Verdict.AHEAD:
            self.refuse(RFID_COMMAND, self.cache.ahead_problem(cmd.seq))
        elif verdict is Verdict.ENDED:
            self.refuse(RFID_COMMAND, f'ended: {cmd} after the search has ended')
        elif verdict is Verdict.EXECUTE and self.live.busy:
            self.refuse(RFID_COMMAND, f'busy: {cmd} while {self.live.current.command} is being performed')
        elif verdict is Verdict.EXECUTE:
            self.live.start(cmd, time.time())

    def _tick(self) -> None:
        self.link.poll(time.time())
        reads = self.link.drain()
        if len(reads):
            self._add(reads)
        answer = self.live.take_due(time.time())
        if answer is not None:
            t = self._now()
            self.cache.store(answer.command.seq, (answer, t), t, answer.command.kind is CommandKind.DONE)
        due = self.cache.take_due(self._now())
        if due is not None:
            answer, t = due
            self.topics.publish(t, answer.result, answer.stream, answer.duration)

    def _add(self, reads) -> None:
        if not self.epc:
            self.epc = reads.epc[0]
            self.get_logger().info(f'following tag {self.epc} (the first read; set epc to choose)')
        mine = reads.of(self.epc)
        self.other_reads += len(reads) - len(mine)
        carrier = channel_carriers(mine.channel, self.table_hz)
        bad = ~np.isfinite(carrier)
        if bad.any():
            self.off_table_reads += int(bad.sum())
            self.get_logger().warning(f'reads on ChannelIndex {int(mine.channel[bad][0])}, not in channels_mhz '
                                      f'({len(self.table_hz)} carriers): {self.off_table_reads} reads dropped so far',
                                      throttle_duration_sec=10.0)
        ok = ~bad
        self.live.add(mine.arrival[ok], mine.t[ok], mine.phase[ok], mine.rssi[ok], carrier[ok])

    def destroy_node(self) -> None:
        self.link.close()
        super().destroy_node()
