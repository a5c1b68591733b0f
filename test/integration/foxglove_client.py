"""A minimal, independent client of the Foxglove WebSocket protocol (``foxglove.websocket.v1``) for the tests.

Subprotocol: the Foxglove SDK's server (and the C++ foxglove_bridge from 3.0) accepts only the name
``foxglove.sdk.v1`` in the handshake, for the same messages as ``foxglove.websocket.v1`` (Foxglove's
maintainers: the protocol renamed, unchanged so far). The client offers both names, the new first,
and ``subprotocol`` is the one the server chose.

Written from the protocol's specification, not from the SDK the bridge uses: the ``websockets``
package speaks the WebSocket, this speaks the protocol's JSON and binary messages. It subscribes
to advertised channels, keeps every message it receives (per topic: log time and payload) and
decodes a payload with the advertised schema through ``mcap_ros2``'s decoder (Foxglove's own
Python decoder of ``ros2msg`` + ``cdr``), the way the Foxglove app decodes it.

Protocol (server → client): text frames are JSON with ``op`` ``serverInfo``, ``advertise``
(``channels``: ``id``, ``topic``, ``encoding``, ``schemaName``, ``schema``, ``schemaEncoding``),
``unadvertise`` (``channelIds``), ``status``; binary frames start with an opcode byte: 1 = message
data (uint32 LE subscription id, uint64 LE log time in ns, payload), 2 = time (uint64 LE ns).
Client → server: ``{"op": "subscribe", "subscriptions": [{"id", "channelId"}]}`` and ``unsubscribe``.
"""

from __future__ import annotations

import contextlib
import json
import struct
import threading
from collections import defaultdict

SUBPROTOCOLS = ['foxglove.sdk.v1', 'foxglove.websocket.v1']
MESSAGE_DATA = 0x01
TIME = 0x02


class FoxgloveClient:
    """Connects at once; a thread reads every frame until ``close()``."""

    def __init__(self, url: str, timeout: float = 60.0, follow: tuple[str, ...] = ()) -> None:
        """``follow``: topics subscribed from the reading thread the moment they are advertised, every time
        (what the Foxglove app does for the topics of its panels)."""
        from websockets.sync.client import connect

        self._stack = contextlib.ExitStack()  # websockets wants its connection used as a context manager
        self.ws = self._stack.enter_context(connect(url, subprotocols=SUBPROTOCOLS, open_timeout=timeout,
                                                    max_size=None))
        self.subprotocol = self.ws.subprotocol
        self.lock = threading.Lock()
        self.server_info: dict | None = None
        self.channels: dict[str, dict] = {}  # topic -> the advertised channel
        self.unadvertised: list[str] = []  # topics, in order
        self.messages: dict[str, list[tuple[int, bytes]]] = defaultdict(list)  # topic -> (log time, payload)
        self.times: list[int] = []
        self.statuses: list[dict] = []  # the server's status messages (an 'Unknown channel ID' among them)
        self.advertisements: list[tuple[str, int]] = []  # (topic, channel id), in order
        self.follow = frozenset(follow)
        self._subs: dict[int, str] = {}  # subscription id -> topic
        self._next_sub = 1
        self._stop = threading.Event()
        self.error: BaseException | None = None
        self.thread = threading.Thread(target=self._read, daemon=True)
        self.thread.start()

    def _read(self) -> None:
        try:
            while not self._stop.is_set():
                try:
                    frame = self.ws.recv(timeout=0.2)
                except TimeoutError:
                    continue
                if isinstance(frame, str):
                    self._on_json(json.loads(frame))
                elif frame[0] == MESSAGE_DATA:
                    sub, log_time = struct.unpack_from('<IQ', frame, 1)
                    with self.lock:
                        topic = self._subs.get(sub)
                        if topic is not None:
                            self.messages[topic].append((log_time, bytes(frame[13:])))
                elif frame[0] == TIME:
                    with self.lock:
                        self.times.append(struct.unpack_from('<Q', frame, 1)[0])
        except Exception as exc:  # connection closed by the server, or a protocol error: the test sees it
            if not self._stop.is_set():
                self.error = exc

    def _on_json(self, msg: dict) -> None:
        with self.lock:
            if msg['op'] == 'serverInfo':
                self.server_info = msg
            elif msg['op'] == 'advertise':
                for ch in msg['channels']:
                    self.channels[ch['topic']] = ch
                    self.advertisements.append((ch['topic'], ch['id']))
            elif msg['op'] == 'status':
                self.statuses.append(msg)
            elif msg['op'] == 'unadvertise':
                gone = set(msg['channelIds'])
                for topic in [t for t, ch in self.channels.items() if ch['id'] in gone]:
                    del self.channels[topic]
                    self.unadvertised.append(topic)
        if msg['op'] == 'advertise' and (now := [ch['topic'] for ch in msg['channels'] if ch['topic'] in self.follow]):
            self.subscribe(*now)

    def subscribe(self, *topics: str) -> None:
        subs = []
        with self.lock:
            for topic in topics:
                sid, self._next_sub = self._next_sub, self._next_sub + 1
                self._subs[sid] = topic
                subs.append({'id': sid, 'channelId': self.channels[topic]['id']})
        self.ws.send(json.dumps({'op': 'subscribe', 'subscriptions': subs}))

    def advertised(self, *topics: str) -> bool:
        with self.lock:
            return all(t in self.channels for t in topics)

    def received(self, *topics: str, n: int = 1) -> bool:
        with self.lock:
            return all(len(self.messages.get(t, ())) >= n for t in topics)

    def decode(self, topic: str, index: int = -1):
        """Message ``index`` of ``topic`` decoded with the advertised schema (mcap_ros2), as Foxglove decodes it."""
        from mcap.records import Schema
        from mcap_ros2.decoder import DecoderFactory

        with self.lock:
            ch = self.channels[topic]
            payload = self.messages[topic][index][1]
        schema = Schema(id=1, name=ch['schemaName'], encoding=ch['schemaEncoding'], data=ch['schema'].encode())
        return DecoderFactory().decoder_for(ch['encoding'], schema)(payload)

    def payload(self, topic: str, index: int = -1) -> bytes:
        with self.lock:
            return self.messages[topic][index][1]

    def close(self) -> None:
        self._stop.set()
        self._stack.close()
        self.thread.join(timeout=10)
