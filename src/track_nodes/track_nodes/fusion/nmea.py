"""NMEA 0183 AIS sentences (``!AIVDM``/``!AIVDO``) → decoded reports, through pyais, with bounded memory.

Not a node: the decoding step of ``ais_nmea_source``, kept apart so it is tested without ROS and
so the node stays an adapter (the pyais dependency lives here, as sllurp lives in ``rfid/llrp.py``).

A line is what receivers, decoders and their capture files carry, in any of these forms:

- ``!AIVDM,1,1,,B,<payload>,0*hh`` (a plain sentence; ``!AIVDO``: the own ship's reports);
- ``\\s:station,c:1452603731*hh\\!AIVDM,...`` (an NMEA 4.0 tag block: ``c`` is the receiver's
  UNIX time in seconds, or milliseconds when it exceeds 10¹¹; a tag block with a bad checksum is
  refused);
- ``2016-01-12T13:02:11.5Z !AIVDM,...`` or ``1452603731.5 !AIVDM,...`` (a receiver timestamp before
  the sentence) or ``!AIVDM,...*hh,1452603731`` (after it, as some aggregators append it).

``Decoder.feed(line, now)`` returns the reports the line completes (none for the first fragment of
a multi-part message) and counts what it refuses, each with a one-line reason whose field comes
first (``checksum: ...``, ``payload: ...``, ``msg_type: ...``), the form ``TrackNode.refuse``
counts by. Times: a report carries the receiver time of its (first) sentence when the line has
one, else ``None`` (the node stamps it on arrival).

Multi-part messages (types 5 and 19 take two sentences) are assembled per (channel, sequence id,
fragment count), bounded by ``max_pending`` groups (oldest dropped first) and ``fragment_timeout``
seconds, both counted (``dropped_fragments``): no stream can grow memory.

Message types used: 1, 2, 3 (class A position), 18, 19 (class B position; 19 also carries name
and type), 5 (class A static and voyage data), 24 (class B static data, parts A and B). The
other types pyais knows (base stations, aids to navigation, binary messages...) are counted in
``skipped`` by type, not refused: they are valid traffic this source has no use for. A type pyais
does not know is refused.
"""

from __future__ import annotations

import math
from collections import Counter, OrderedDict
from dataclasses import dataclass, field
from datetime import UTC, datetime

from pyais import NMEAMessage, TagBlock
from pyais.exceptions import AISBaseException

from track_core.ais.live import POSITION_TYPES, STATIC_TYPES, PositionFields

MAX_LINE = 1024           # longer lines are refused before parsing (a sentence is at most 82 characters)
MS_THRESHOLD = 1e11       # a c: value above this is in milliseconds
MAX_RECEIVER_TIME = 2.0**31   # a receiver time at or beyond this cannot stamp a message (int32 seconds)


@dataclass(frozen=True)
class Position:
    """A decoded position report and its receiver time [s UNIX] (None: stamp it on arrival)."""

    fields: PositionFields
    t: float | None
    own: bool             # from !AIVDO: the receiving ship's own report


@dataclass(frozen=True)
class Static:
    """Static data of an MMSI (any field may be empty: a type 24 part carries half of it)."""

    mmsi: int
    name: str
    ship_type: int
    callsign: str
    t: float | None


def _clean(text) -> str:
    return '' if text is None else str(text).replace('@', '').strip()


def _number_time(text: str) -> float | None:
    try:
        v = float(text)
    except ValueError:
        return None
    if not math.isfinite(v) or v <= 0:
        return None
    return v / 1000.0 if v > MS_THRESHOLD else v


def _parse_time(text: str) -> float | None:
    """A receiver timestamp: UNIX seconds (or ms), or an ISO 8601 date-time (UTC when no zone)."""
    text = text.strip()
    if not text:
        return None
    v = _number_time(text)
    if v is not None:
        return v
    try:
        d = datetime.fromisoformat(text.replace('Z', '+00:00'))
    except ValueError:
        return None
    if d.tzinfo is None:
        d = d.replace(tzinfo=UTC)
    return d.timestamp()


def split_line(line: bytes) -> tuple[float | None, bytes, str | None]:  # noqa: PLR0911 - one reason per way
    """A line → (receiver time [s UNIX] or None, the sentence ``!...*hh``, None), or a reason it is no sentence.

    The receiver time is the tag block's ``c:``, else a timestamp before the sentence, else one after
    its checksum (module docstring). Used by the decoder and by ``nmea_play``, which paces a capture by it.
    """
    if len(line) > MAX_LINE:
        return None, b'', f'line: {len(line)} bytes, longer than {MAX_LINE}'
    if not line.isascii():
        return None, b'', 'line: non-ASCII bytes'
    line = line.strip()
    t = None
    if line.startswith(b'\\'):
        end = line.find(b'\\', 1)
        if end < 0:
            return None, b'', 'tag_block: not closed by "\\"'
        tb = TagBlock(line[1:end])
        tb.init()
        if not tb.is_valid:
            return None, b'', f'tag_block: checksum or format wrong in {line[:end + 1].decode()!r}'
        if tb.receiver_timestamp is not None:
            t = _number_time(str(tb.receiver_timestamp))
        line = line[end + 1:]
    start = line.find(b'!')
    if start < 0:
        return t, b'', f'sentence: no "!" (not an AIS sentence): {line[:40].decode()!r}'
    if start > 0:   # a receiver timestamp before the sentence
        t = _parse_time(line[:start].decode()) if t is None else t
    line = line[start:]
    star = line.rfind(b'*')
    if star < 0 or len(line) < star + 3:
        return t, b'', f'sentence: truncated (no "*hh" checksum): {line[:60].decode()!r}'
    tail = line[star + 3:].lstrip(b',').strip()
    if tail and t is None:   # a receiver timestamp after the checksum
        t = _number_time(tail.decode())
    return t, line[:star + 3], None


@dataclass
class _Group:
    first: float
    t: float | None
    parts: dict = field(default_factory=dict)


@dataclass
class Decoder:
    """Lines → ``Position`` / ``Static`` reports; refusals counted and kept as their reasons (module docstring)."""

    max_pending: int = 256
    fragment_timeout: float = 5.0
    sentences: int = 0
    refused: Counter = field(default_factory=Counter)      # reason kind → count
    skipped: Counter = field(default_factory=Counter)      # message type → count
    dropped_fragments: int = 0
    pending: OrderedDict = field(default_factory=OrderedDict)

    def feed(self, line: bytes | str, now: float) -> tuple[list, list[str]]:
        """One line at time ``now`` [s, any monotonic clock] → (reports, reasons of what was refused)."""
        if isinstance(line, str):
            line = line.encode('ascii', 'replace')
        reasons: list[str] = []
        self._expire(now)
        line = line.strip()
        if not line:
            return [], reasons
        self.sentences += 1
        out, reason = self._line(line, now)
        if reason is not None:
            self.refused[reason.partition(':')[0]] += 1
            reasons.append(reason)
        return out, reasons

    # -- one line --------------------------------------------------------------------------
    def _line(self, line: bytes, now: float):
        t, sentence, reason = split_line(line)
        if reason is None and t is not None and not t < MAX_RECEIVER_TIME:
            reason = f'receiver_time: {t:.6g} s is beyond what a ROS stamp holds (2^31 s, in 2038)'
        if reason is not None:
            return [], reason
        if sentence[3:6] not in (b'VDM', b'VDO'):
            return [], f'sentence: {sentence[:6].decode()!r} is not !AIVDM or !AIVDO'
        try:
            msg = NMEAMessage(sentence)
        except (AISBaseException, ValueError, IndexError) as exc:
            return [], f'sentence: malformed ({type(exc).__name__}): {sentence[:60].decode()!r}'
        if not msg.is_valid:
            return [], f'checksum: {sentence[-2:].decode()} does not match the sentence {sentence[:40].decode()!r}...'
        if msg.frag_cnt == 1:
            return self._decode(msg, t, sentence[3:6] == b'VDO')
        return self._fragment(msg, t, now, sentence[3:6] == b'VDO')

    def _fragment(self, msg, t, now: float, own: bool):
        key = (msg.channel, msg.seq_id, msg.frag_cnt)
        group = self.pending.get(key)
        if group is not None and msg.frag_num in group.parts:   # a new message reuses the key: the old is lost
            del self.pending[key]
            self.dropped_fragments += len(group.parts)
            group = None
        if group is None:
            if msg.frag_num != 1:
                self.dropped_fragments += 1
                return [], f'fragment: part {msg.frag_num} of {msg.frag_cnt} without its first part'
            group = self.pending[key] = _Group(now, t)
            while len(self.pending) > self.max_pending:
                _, old = self.pending.popitem(last=False)
                self.dropped_fragments += len(old.parts)
        group.parts[msg.frag_num] = msg
        if len(group.parts) < msg.frag_cnt:
            return [], None
        del self.pending[key]
        try:
            whole = NMEAMessage.assemble_from_iterable([group.parts[k] for k in sorted(group.parts)])
        except (AISBaseException, ValueError) as exc:
            return [], f'fragment: cannot assemble ({type(exc).__name__})'
        return self._decode(whole, group.t, own)

    def _expire(self, now: float) -> None:
        while self.pending:
            key, group = next(iter(self.pending.items()))
            if now - group.first <= self.fragment_timeout:
                break
            del self.pending[key]
            self.dropped_fragments += len(group.parts)

    # -- one message -------------------------------------------------------------------------
    def _decode(self, msg, t, own: bool):
        try:
            d = msg.decode()
        except AISBaseException as exc:
            return [], f'msg_type: {msg.ais_id} is unknown ({type(exc).__name__})'
        except (ValueError, IndexError, TypeError) as exc:
            return [], f'payload: cannot decode type {msg.ais_id} ({type(exc).__name__})'
        kind = int(d.msg_type)
        if kind not in POSITION_TYPES and kind not in STATIC_TYPES:
            self.skipped[kind] += 1
            return [], None
        out = []
        if kind in POSITION_TYPES:
            values = (d.mmsi, d.lat, d.lon, d.speed, d.course, d.heading, d.accuracy)
            if any(v is None for v in values):
                return [], f'payload: truncated type {kind} message (fields missing) from MMSI {d.mmsi}'
            out.append(Position(PositionFields(kind, int(d.mmsi), float(d.lat), float(d.lon), float(d.speed),
                                               float(d.course), float(d.heading), bool(d.accuracy)), t, own))
        if kind in STATIC_TYPES:
            name = _clean(getattr(d, 'shipname', None))
            ship_type = getattr(d, 'ship_type', None)
            callsign = _clean(getattr(d, 'callsign', None))
            if d.mmsi is None:
                return [], f'payload: truncated type {kind} message (no MMSI)'
            out.append(Static(int(d.mmsi), name, int(ship_type or 0), callsign, t))
        return out, None
