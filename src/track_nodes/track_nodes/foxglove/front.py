"""The WebSocket front of ``track-foxglove``: what a client meets before the Foxglove SDK's server.

The SDK's server (``foxglove-sdk``) speaks the protocol well but the WebSocket around it badly for a
user: a client that offers another subprotocol (Foxglove Studio 1.x and older Lichtblick offer only
``foxglove.websocket.v1``) is refused with "Missing expected sec-websocket-protocol header" although
it sent one, and a client's close frame is never answered (the client sees 1006, an abnormal
close). The front is a WebSocket server of its own (the ``websockets`` package) on the bridge's
address and port:

- the handshake: a client that does not offer ``foxglove.sdk.v1`` gets HTTP 400 with one line that
  says what it offered and what this server speaks (``refusal``), and the bridge logs one line, at
  most every ``REFUSAL_THROTTLE`` s with the count;
- each accepted client gets its own connection to the SDK's server (on 127.0.0.1, a free port) and
  the frames are relayed as they are, both ways, in order; a client that reads slowly holds its
  relay back, so the SDK's own queue for it drops the oldest data, as it would for the client;
- a client's close frame is answered (1000, the close handshake) and its SDK connection closed; when
  the bridge stops, every client gets 1001 (going away).

The frames are not parsed: the protocol stays the SDK's. Everything runs on one asyncio loop in a
thread of its own.
"""

from __future__ import annotations

import asyncio
import contextlib
import threading
from collections.abc import Callable
from http import HTTPStatus

SUBPROTOCOL = 'foxglove.sdk.v1'  # the SDK's name for the v1 messages of the Foxglove WebSocket protocol
UPSTREAM_CLOSE_TIMEOUT = 0.5  # [s] the SDK's server does not answer a close frame: do not wait for it
START_TIMEOUT = 30.0  # [s] to bind the front


def offered(header_values: list[str]) -> list[str]:
    """The subprotocols a handshake offers (``Sec-WebSocket-Protocol``: one or more comma-separated lists)."""
    return [p.strip() for value in header_values for p in value.split(',') if p.strip()]


def refusal(protocols: list[str]) -> str:
    """The one line a client gets when it does not offer ``foxglove.sdk.v1``."""
    said = f'offered {", ".join(protocols)}' if protocols else 'offered no subprotocol'
    return (f'this Foxglove WebSocket server speaks {SUBPROTOCOL} (the v1 protocol under its current name); '
            f'the client {said}: use the Foxglove app, or a client that offers {SUBPROTOCOL}')


class Front:
    """Serve ``host:port`` and relay every accepted client to the SDK's server on ``127.0.0.1:upstream_port``.

    ``on_refusal(line)`` is called (from the front's thread) for every refused handshake. ``OSError``
    when the address cannot be bound."""

    def __init__(self, host: str, port: int, upstream_port: int, on_refusal: Callable[[str], None]) -> None:
        self.upstream = f'ws://127.0.0.1:{upstream_port}'
        self.on_refusal = on_refusal
        self.loop = asyncio.new_event_loop()
        self.thread = threading.Thread(target=self.loop.run_forever, name='foxglove-front', daemon=True)
        self.thread.start()
        try:
            self.server = asyncio.run_coroutine_threadsafe(self._serve(host, port), self.loop).result(START_TIMEOUT)
        except BaseException:
            self._end_loop()
            raise
        self.port = self.server.sockets[0].getsockname()[1]

    async def _serve(self, host: str, port: int):
        from websockets.asyncio.server import serve

        return await serve(self._relay, host, port, subprotocols=[SUBPROTOCOL], process_request=self._check,
                           max_size=None, compression=None)

    def _check(self, connection, request):
        """Refuse, in words, a handshake that does not offer our subprotocol (else websockets goes on)."""
        protocols = offered(request.headers.get_all('Sec-WebSocket-Protocol'))
        if SUBPROTOCOL in protocols:
            return None
        line = refusal(protocols)
        with contextlib.suppress(Exception):  # the log must not break the server
            self.on_refusal(line)
        return connection.respond(HTTPStatus.BAD_REQUEST, line + '\n')

    async def _relay(self, client) -> None:
        from websockets.asyncio.client import connect
        from websockets.exceptions import WebSocketException

        try:
            async with connect(self.upstream, subprotocols=[SUBPROTOCOL], max_size=None, compression=None,
                               ping_interval=None, close_timeout=UPSTREAM_CLOSE_TIMEOUT) as sdk:
                await _pump_both(client, sdk)
        except (OSError, WebSocketException):
            pass  # the SDK's server stopped or refused: the client is closed below
        if client.close_code is None:
            await client.close(1001, 'the server is stopping')

    def stop(self) -> None:
        """Close every client with 1001 and the listening socket; end the thread. Idempotent."""
        if self.thread.is_alive():
            with contextlib.suppress(Exception):
                asyncio.run_coroutine_threadsafe(self._close(), self.loop).result(10.0)
            self._end_loop()

    async def _close(self) -> None:
        self.server.close(close_connections=True)
        await self.server.wait_closed()

    def _end_loop(self) -> None:
        self.loop.call_soon_threadsafe(self.loop.stop)
        self.thread.join(timeout=10.0)


async def _pump_both(client, sdk) -> None:
    """Relay frames both ways until either side closes."""

    async def pump(source, sink) -> None:
        async for frame in source:
            await sink.send(frame)

    tasks = [asyncio.create_task(pump(client, sdk)), asyncio.create_task(pump(sdk, client))]
    try:
        await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
    finally:
        for task in tasks:
            task.cancel()
        for task in tasks:
            with contextlib.suppress(BaseException):
                await task
