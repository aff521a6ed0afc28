"""The websocket side: accept rosbridge clients and pump frames between them and the Broker."""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import Callable

from websockets.asyncio.server import Server, ServerConnection, serve
from websockets.exceptions import ConnectionClosed

from .protocol import Broker, Client

log = logging.getLogger("simulator.server")


class RosbridgeServer:
    def __init__(self, broker: Broker, clients_changed: Callable[[], None]) -> None:
        self.broker = broker
        self.clients_changed = clients_changed
        self.server: Server | None = None
        self.port = 0
        self.connections: set[ServerConnection] = set()

    async def start(self, host: str, port: int) -> None:
        # rosbridge: no permessage-deflate, no pings, no practical frame size limit
        self.server = await serve(
            self._handle, host, port, compression=None, ping_interval=None, max_size=2**28,
            max_queue=None, close_timeout=1.0, reuse_address=True,
        )
        self.port = self.server.sockets[0].getsockname()[1]

    async def stop(self) -> None:
        if self.server is None:
            return
        self.server.close(close_connections=False)
        for ws in list(self.connections):
            ws.transport.abort()  # the robot vanishing: clients see the TCP connection drop
        try:
            await asyncio.wait_for(self.server.wait_closed(), 3.0)
        except TimeoutError:
            log.warning("websocket server did not close within 3 s")

    async def _handle(self, ws: ServerConnection) -> None:
        self.connections.add(ws)
        broker = self.broker
        address = ws.remote_address[0] if ws.remote_address else ""
        client = Client(broker, ws.send, address)
        broker.clients[client.id] = client
        self.clients_changed()
        writer = asyncio.get_running_loop().create_task(self._write(client))
        try:
            async for raw in ws:
                client.handle(raw)
        except ConnectionClosed:
            pass
        finally:
            client.closed = True
            writer.cancel()
            self.connections.discard(ws)
            broker.disconnect(client)
            self.clients_changed()

    @staticmethod
    async def _write(client: Client) -> None:
        with contextlib.suppress(ConnectionClosed):
            await client.run_writer()
