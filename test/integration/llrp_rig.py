"""An LLRP reader on localhost for the tests of ``rfid_llrp_reader``: llrpkit's emulator, made to
answer as the LLRP 1.1 standard says where sllurp relies on it, with scripted tag phases.

llrpkit's ``LLRPEmulator`` speaks the wire protocol (connection event, capabilities, ROSpecs, the
Impinj extensions). Three departures from LLRP 1.1 stop sllurp's bring-up, so this subclass answers:

- ``ENABLE_EVENTS_AND_REPORTS`` has no response message (§14.1.1; llrpkit sends ERROR_MESSAGE,
  which sllurp takes for the answer to the next request);
- ``DELETE_ROSPEC`` / ``DELETE_ACCESSSPEC`` with id 0 mean all of them (§10.1.3);
- a ROSpec with an Immediate start trigger becomes Active when enabled (§10.2.1.1.1).

Tag reports come from ``phase_of(t)`` instead of random numbers: the wrapped phase (rad, LLRP sign)
and the channel index of the one tag at wall time ``t``, so a test knows the dφ a MOVE must give.
A read is taken, stamped and phased at its scheduled time ``t``, every 1/``reads_per_sec``, as a
reader's radio does whatever its host is doing: when this process is starved (a busy machine), the
reads it owes go out late in a burst, each with its own time, and not as a gap followed by a bunch
of reads stamped at the send time (that stream, line fits over reads sharing one instant and a
150 ms hole, is no reader's and fails MOVEs that a real reader's reads would pass).
``ReaderRig`` runs it in a child process (``python llrp_rig.py PORT OMEGA CHANNELS HOP_S``).
"""

from __future__ import annotations

import asyncio
import math
import select
import signal
import subprocess
import sys
import time
from collections.abc import Callable

from llrpkit.emulator import LLRPEmulator
from llrpkit.emulator.core import EmulatedTag
from llrpkit.protocol import impinj, messages, params

EPC = 'E20000000000000000005A01'
IMMEDIATE = 1  # ROSpecStartTriggerType


class ScriptedReader(LLRPEmulator):
    """One tag read ``reads_per_sec`` times a second on antenna 1, phase and channel from ``phase_of``."""

    def __init__(self, phase_of: Callable[[float], tuple[float, int]], port: int = 0, reads_per_sec: float = 300.0):
        super().__init__(port=port, tags=[EmulatedTag(epc=bytes.fromhex(EPC))], reads_per_sec=reads_per_sec)
        self.phase_of = phase_of
        self.sent = 0

    async def _handle_message(self, msg) -> None:
        if isinstance(msg, messages.ENABLE_EVENTS_AND_REPORTS):
            return
        if isinstance(msg, messages.DELETE_ROSPEC) and msg.ro_spec_id == 0:
            self._rospecs.clear()
            self._sync_reporting()
            await self._send(messages.DELETE_ROSPEC_RESPONSE(llrp_status=self._status_ok()),
                             message_id=msg.message_id)
            return
        if isinstance(msg, messages.DELETE_ACCESSSPEC) and msg.access_spec_id == 0:
            self._accessspecs.clear()
            await self._send(messages.DELETE_ACCESSSPEC_RESPONSE(llrp_status=self._status_ok()),
                             message_id=msg.message_id)
            return
        await super()._handle_message(msg)
        if isinstance(msg, messages.ENABLE_ROSPEC) and msg.ro_spec_id in self._rospecs:
            spec, state = self._rospecs[msg.ro_spec_id]
            trigger = spec.ro_boundary_spec.ro_spec_start_trigger.ro_spec_start_trigger_type
            if state == 'Enabled' and trigger == IMMEDIATE:
                self._rospecs[msg.ro_spec_id] = (spec, 'Active')
                self._sync_reporting()

    async def _report_loop(self) -> None:
        period = 1.0 / self.reads_per_sec
        next_due = time.time()
        while True:
            next_due += period
            await asyncio.sleep(max(0.0, next_due - time.time()))
            taken = next_due   # the radio reads on its own schedule; this process only reports (module doc)
            phase, channel = self.phase_of(taken)
            units = round(phase % (2.0 * math.pi) / (2.0 * math.pi) * 4096) % 4096   # Impinj: 4096 = 2π
            us = round(taken * 1e6)
            trd = params.TagReportData(
                epc_parameter=params.EPC_96(epc=bytes.fromhex(EPC)),
                antenna_id=params.AntennaID(antenna_id=1),
                peak_rssi=params.PeakRSSI(peak_rssi=-50),
                channel_index=params.ChannelIndex(channel_index=channel),
                first_seen_timestamp_utc=params.FirstSeenTimestampUTC(microseconds=us),
                last_seen_timestamp_utc=params.LastSeenTimestampUTC(microseconds=us),
                tag_seen_count=params.TagSeenCount(tag_count=1))
            trd.custom.append(impinj.ImpinjPeakRSSI(rssi=-5000))
            trd.custom.append(impinj.ImpinjRFPhaseAngle(phase_angle=units))
            await self._send(messages.RO_ACCESS_REPORT(tag_report_datas=[trd]))
            self.sent += 1


class ReaderRig:
    """A ``ScriptedReader`` in a process of its own (so a busy test process cannot stall its reads), phase
    ``omega``·t wrapped, hopping over ``channels`` ChannelIndex values every ``hop_s``: ``start()``, ``stop()``
    (the reader goes away: its connection drops), ``start()`` again on the same port (it comes back)."""

    def __init__(self, omega: float, channels: int = 1, hop_s: float = 0.2) -> None:
        self.args = [str(omega), str(channels), str(hop_s)]
        self.port = 0
        self.proc: subprocess.Popen | None = None

    def start(self, timeout: float = 60.0) -> int:
        self.proc = subprocess.Popen([sys.executable, __file__, str(self.port), *self.args], stdout=subprocess.PIPE,
                                     text=True)
        ready = select.select([self.proc.stdout], [], [], timeout)[0]
        line = self.proc.stdout.readline() if ready else ''
        if not line.startswith('port '):
            self.stop()
            raise RuntimeError(f'the LLRP reader emulator did not start: {line!r}')
        self.port = int(line.split()[1])
        return self.port

    def stop(self) -> None:
        if self.proc is not None:
            self.proc.terminate()
            self.proc.wait(timeout=30)
            self.proc = None

    def close(self) -> None:
        self.stop()


def _serve(port: int, omega: float, channels: int, hop_s: float) -> None:
    def phase_of(t: float) -> tuple[float, int]:
        return (omega * t) % (2.0 * math.pi), 1 + int(t / hop_s) % channels

    async def main() -> None:
        reader = ScriptedReader(phase_of, port=port)
        await reader.start()
        print(f'port {reader.port}', flush=True)
        stop = asyncio.Event()
        asyncio.get_running_loop().add_signal_handler(signal.SIGTERM, stop.set)
        await stop.wait()
        await reader.stop()

    asyncio.run(main())


if __name__ == '__main__':
    _serve(int(sys.argv[1]), float(sys.argv[2]), int(sys.argv[3]), float(sys.argv[4]))
