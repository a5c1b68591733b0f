"""The LLRP link of ``rfid_llrp_reader``: one reader over sllurp, its reads queued, reconnected when it drops.

Not a node. ``LlrpLink`` owns a ``sllurp.llrp.LLRPReaderClient``: it connects from a thread of its
own (a TCP connect may block for the socket timeout; the executor must not), configures the reader
(antennas, transmit power, the Impinj extensions for the RF phase angle and the peak RSSI in
0.01 dBm, one report per read) and starts inventory. sllurp calls ``_on_tags`` from its socket
thread; each read is stamped with its arrival time there and queued (``queue.SimpleQueue``) for the
node's timer, which ``drain``s it. When the reader goes away (the connection drops, or a connect
fails), the link tries again every ``retry_s`` with a fresh client (sllurp's own reconnect gives up
after a few tries a minute apart) and counts what happened (``connects``, ``drops``, ``failures``).

An accepted TCP connection is not yet a reader: anything listening on the port accepts one. The
link is ``up`` (and says "connected") only after the LLRP handshake: the reader's answer to
GET_READER_CAPABILITIES (sllurp's state CONNECTED, which needs the reader's connection event
first) or, whichever comes first, its first tag report. A peer that has not answered
``handshake_s`` after the TCP connect, or that closes the connection before answering, is refused:
the connection is closed, counted (``failures``, ``refusals``) and retried like a failed connect,
with one warning line per run of refusals (the next line only after a real connection).

A read (LLRP TagReportData, as sllurp decodes it) → one row: arrival time (s, the link's clock),
reader time (``LastSeenTimestampUTC`` µs → s), EPC (hex, upper case), antenna, ChannelIndex, phase
(``ImpinjRFPhaseAngle``: 4096 units a turn → rad in [0, 2π)), RSSI (``ImpinjPeakRSSI`` / 100, else
``PeakRSSI``, dBm). A read without a phase angle (the extension not granted) is dropped and counted
(``no_phase``).
"""

from __future__ import annotations

import contextlib
import math
import queue
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

PHASE_UNITS = 4096            # ImpinjRFPhaseAngle: 0..4095 for one turn (2π)
DEFAULT_PORT = 5084           # IANA port of LLRP


@dataclass(frozen=True)
class Reads:
    """Reads of one drain, as arrays (module doc); ``epc`` a list of hex strings."""

    arrival: np.ndarray
    t: np.ndarray
    epc: list
    antenna: np.ndarray
    channel: np.ndarray
    phase: np.ndarray
    rssi: np.ndarray

    def of(self, epc: str) -> Reads:
        keep = np.array([e == epc for e in self.epc], dtype=bool)
        return Reads(self.arrival[keep], self.t[keep], [e for e in self.epc if e == epc], self.antenna[keep],
                     self.channel[keep], self.phase[keep], self.rssi[keep])

    def __len__(self) -> int:
        return self.arrival.size


def tag_row(tag: dict, arrival: float) -> tuple | None:
    """One sllurp tag dict → (arrival, t s, EPC, antenna, channel, phase rad, RSSI dBm), None without a phase."""
    units = tag.get('ImpinjRFPhaseAngle')
    if units is None:
        return None
    epc = tag.get('EPC-96', tag.get('EPC', b''))
    epc = epc.decode() if isinstance(epc, bytes) else str(epc)
    rssi = tag['ImpinjPeakRSSI'] / 100.0 if 'ImpinjPeakRSSI' in tag else float(tag.get('PeakRSSI', math.nan))
    t_us = tag.get('LastSeenTimestampUTC', tag.get('FirstSeenTimestampUTC'))
    return (arrival, t_us * 1e-6 if t_us is not None else arrival, epc.upper(), int(tag.get('AntennaID', 1)),
            int(tag.get('ChannelIndex', 0)), 2.0 * math.pi * (int(units) % PHASE_UNITS) / PHASE_UNITS, rssi)


def rows_to_reads(rows: list[tuple]) -> Reads:
    if not rows:
        e = np.empty(0)
        return Reads(e, e, [], e.astype(int), e.astype(int), e, e)
    a, t, epc, ant, ch, ph, rssi = zip(*rows, strict=True)
    return Reads(np.array(a), np.array(t), list(epc), np.array(ant, int), np.array(ch, int), np.array(ph),
                 np.array(rssi, float))


def reader_config(antennas: list[int], tx_power_dbm: float) -> dict:
    """sllurp ``LLRPReaderConfig`` settings: inventory on ``antennas``, one report per read, phase and RSSI."""
    selector = {k: False for k in ('EnableROSpecID', 'EnableSpecIndex', 'EnableInventoryParameterSpecID',
                                   'EnableFirstSeenTimestamp', 'EnableAccessSpecID')}
    selector.update({k: True for k in ('EnableAntennaID', 'EnableChannelIndex', 'EnablePeakRSSI',
                                       'EnableLastSeenTimestamp', 'EnableTagSeenCount')})
    cfg = {'antennas': list(antennas), 'report_every_n_tags': 1, 'reconnect': False, 'start_inventory': True,
           'tag_content_selector': selector, 'impinj_reports': True,
           'impinj_tag_content_selector': {'EnableRFPhaseAngle': True, 'EnablePeakRSSI': True,
                                           'EnableRFDopplerFrequency': False}}
    if tx_power_dbm > 0.0:
        cfg['tx_power_dbm'] = tx_power_dbm
    else:
        cfg['tx_power'] = 0    # sllurp: power index 0 = the reader's maximum
    return cfg


class LlrpLink:
    """One reader over LLRP (module doc); ``poll(now)`` from a timer keeps it connected."""

    def __init__(self, host: str, port: int, settings: dict, retry_s: float = 2.0,
                 log: Callable[[str], None] = print, handshake_s: float = 5.0,
                 warn: Callable[[str], None] | None = None) -> None:
        self.host, self.port, self.settings, self.retry_s, self.log = host, port, settings, retry_s, log
        self.handshake_s = handshake_s
        self.warn = warn if warn is not None else log
        self.queue: queue.SimpleQueue = queue.SimpleQueue()
        self.client = None           # the reader, once it has answered in LLRP
        self.pending = None          # a TCP connection waiting for its LLRP answer (module doc)
        self.deadline = math.inf     # when ``pending`` is refused (the ``now`` clock of ``poll``)
        self.connecting = False
        self.closed = False
        self.next_try = 0.0
        self.connects = self.drops = self.failures = self.refusals = self.no_phase = 0
        self.last_error = ''
        self._warned = False         # a refusal line since the last real connection
        self._lock = threading.Lock()

    @property
    def up(self) -> bool:
        client = self.client
        return client is not None and client.is_alive()

    def poll(self, now: float) -> None:
        """Refuse a connection whose LLRP answer is overdue; start a connect attempt when the reader is down
        and the retry time has come."""
        with self._lock:
            if self.pending is not None and now >= self.deadline:
                self._refuse(f'no LLRP answer within {self.handshake_s:g} s of the TCP connect')
            if (self.closed or self.connecting or self.pending is not None or self.up
                    or now < self.next_try):
                return
            self.connecting = True
            self.next_try = now + self.retry_s
        threading.Thread(target=self._connect, name=f'llrp-{self.host}:{self.port}', daemon=True).start()

    def _connect(self) -> None:
        from sllurp.llrp import LLRPReaderClient, LLRPReaderConfig, LLRPReaderState

        client = None
        try:
            client = LLRPReaderClient(self.host, self.port, LLRPReaderConfig(dict(self.settings)),
                                      timeout=max(1.0, min(5.0, self.handshake_s)))
            client.add_tag_report_callback(self._on_tags)
            client.add_disconnected_callback(self._on_disconnected)
            client.add_state_callback(LLRPReaderState.STATE_CONNECTED, self._on_capabilities)
            with self._lock:   # before connect(): the reader may answer before connect() returns
                self.pending, self.deadline = client, math.inf
            client.connect()
        except Exception as exc:   # any failure of the attempt: counted, retried
            with self._lock:
                if client is not None and self.pending is client:
                    self.pending = None
                self.connecting = False
            self.failures += 1
            self.last_error = f'{type(exc).__name__}: {exc}'
            return
        with self._lock:
            self.connecting = False
            if self.pending is client:
                self.deadline = time.time() + self.handshake_s

    def _promote(self, client, how: str) -> None:
        """``client`` has spoken LLRP: it is the reader now (called on sllurp's socket thread)."""
        with self._lock:
            if client is not self.pending or self.closed:
                return
            self.client, self.pending, self.deadline = client, None, math.inf
            self.connects += 1
            self._warned = False
        self.log(f'connected to the reader at {self.host}:{self.port} ({how}; connection {self.connects})')

    def _on_capabilities(self, client, _state) -> None:
        self._promote(client, 'LLRP capabilities answered')

    def _refuse(self, reason: str) -> None:
        """Close the pending connection and count it (``self._lock`` held)."""
        client, self.pending, self.deadline = self.pending, None, math.inf
        self.failures += 1
        self.refusals += 1
        self.last_error = f'refused: {reason}'
        if client is not None:
            with contextlib.suppress(Exception):   # already closed by the peer: nothing left to close
                client.hard_disconnect()
        if not self._warned:
            self._warned = True
            self.warn(f'refused {self.host}:{self.port}: {reason} (not an LLRP reader?); retrying every '
                      f'{self.retry_s:g} s, this line once until a reader answers')

    def _on_tags(self, client, tags: list[dict]) -> None:
        if client is not self.client:
            self._promote(client, 'first tag report')
        now = time.time()
        for tag in tags:
            row = tag_row(tag, now)
            if row is None:
                self.no_phase += 1
            else:
                self.queue.put(row)

    def _on_disconnected(self, client) -> None:
        if self.closed:
            return
        with self._lock:
            if client is self.pending:
                self._refuse('the connection closed before any LLRP answer')
                return
            if client is not self.client:
                return   # a refused connection's own close
        self.drops += 1
        self.log(f'the reader at {self.host}:{self.port} went away (drop {self.drops}); retrying every '
                 f'{self.retry_s:g} s')

    def drain(self) -> Reads:
        rows = []
        while True:
            try:
                rows.append(self.queue.get_nowait())
            except queue.Empty:
                return rows_to_reads(rows)

    def close(self) -> None:
        """Stop inventory and disconnect (bounded wait), then stop retrying."""
        self.closed = True
        with self._lock:
            pending, self.pending = self.pending, None
        if pending is not None:
            pending.hard_disconnect()
        client, self.client = self.client, None
        if client is not None and client.is_alive():
            try:
                client.disconnect(timeout=2.0)
            except Exception:  # already gone: nothing to stop
                client.hard_disconnect()
