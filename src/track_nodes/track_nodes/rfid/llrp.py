"""The LLRP link of ``rfid_llrp_reader``: one reader over sllurp, its reads queued, reconnected when it drops.

Not a node. ``LlrpLink`` owns a ``sllurp.llrp.LLRPReaderClient``: it connects from a thread of its
own (a TCP connect may block for the socket timeout; the executor must not), configures the reader
(antennas, transmit power, the Impinj extensions for the RF phase angle and the peak RSSI in
0.01 dBm, one report per read) and starts inventory. sllurp calls ``_on_tags`` from its socket
thread; each read is stamped with its arrival time there and queued (``queue.SimpleQueue``) for the
node's timer, which ``drain``s it. When the reader goes away (the connection drops, or a connect
fails), the link tries again every ``retry_s`` with a fresh client (sllurp's own reconnect gives up
after a few tries a minute apart) and counts what happened (``connects``, ``drops``, ``failures``).

A read (LLRP TagReportData, as sllurp decodes it) → one row: arrival time (s, the link's clock),
reader time (``LastSeenTimestampUTC`` µs → s), EPC (hex, upper case), antenna, ChannelIndex, phase
(``ImpinjRFPhaseAngle``: 4096 units a turn → rad in [0, 2π)), RSSI (``ImpinjPeakRSSI`` / 100, else
``PeakRSSI``, dBm). A read without a phase angle (the extension not granted) is dropped and counted
(``no_phase``).
"""

from __future__ import annotations

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
                 log: Callable[[str], None] = print) -> None:
        self.host, self.port, self.settings, self.retry_s, self.log = host, port, settings, retry_s, log
        self.queue: queue.SimpleQueue = queue.SimpleQueue()
        self.client = None
        self.connecting = False
        self.closed = False
        self.next_try = 0.0
        self.connects = self.drops = self.failures = self.no_phase = 0
        self.last_error = ''
        self._lock = threading.Lock()

    @property
    def up(self) -> bool:
        return self.client is not None and self.client.is_alive()

    def poll(self, now: float) -> None:
        """Start a connect attempt when the reader is down and the retry time has come."""
        with self._lock:
            if self.closed or self.connecting or self.up or now < self.next_try:
                return
            self.connecting = True
            self.next_try = now + self.retry_s
        threading.Thread(target=self._connect, name=f'llrp-{self.host}:{self.port}', daemon=True).start()

    def _connect(self) -> None:
        from sllurp.llrp import LLRPReaderClient, LLRPReaderConfig

        try:
            client = LLRPReaderClient(self.host, self.port, LLRPReaderConfig(dict(self.settings)))
            client.add_tag_report_callback(self._on_tags)
            client.add_disconnected_callback(self._on_disconnected)
            client.connect()
        except Exception as exc:   # any failure of the attempt: counted, retried
            self.failures += 1
            self.last_error = f'{type(exc).__name__}: {exc}'
            with self._lock:
                self.connecting = False
            return
        with self._lock:
            self.client, self.connecting = client, False
            self.connects += 1
        self.log(f'connected to the reader at {self.host}:{self.port} (connection {self.connects})')

    def _on_tags(self, _client, tags: list[dict]) -> None:
        now = time.time()
        for tag in tags:
            row = tag_row(tag, now)
            if row is None:
                self.no_phase += 1
            else:
                self.queue.put(row)

    def _on_disconnected(self, _client) -> None:
        if self.closed:
            return
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
        client, self.client = self.client, None
        if client is not None and client.is_alive():
            try:
                client.disconnect(timeout=2.0)
            except Exception:  # already gone: nothing to stop
                client.hard_disconnect()
