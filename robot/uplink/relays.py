"""Loopback addresses that reach the robot through its uplink, so nothing else changes.

The link's roslibpy dials the rosbridge relay (``ROSBRIDGE_URL`` points here with ``UPLINK``):
each websocket it opens becomes a rosbridge session on the robot, opened by the agent, message for
message. The video relay (``VIDEO_URL``) answers ``/stream`` and ``/snapshot`` with the robot's
web_video_server's answer. Both listen only while the robot's uplink is open: to the link a robot
that is away looks like a rosbridge port that does not listen, and it reconnects the moment it does.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging

from aiohttp import web
from websockets.asyncio.server import Server, ServerConnection, serve
from websockets.exceptions import ConnectionClosed
from websockets.http11 import Request, Response

from robot.supervisor import spawn
from robot.uplink.tunnel import Channel, ChannelClosed, Tunnel
from uplink_agent import mux

log = logging.getLogger(__name__)


class Relays:
    def __init__(self, *, rosbridge_port: int, video_port: int, max_size: int) -> None:
        self.rosbridge_port = rosbridge_port
        self.video_port = video_port
        self.max_size = max_size
        self.tunnel: Tunnel | None = None
        self._ws: Server | None = None
        self._http: web.AppRunner | None = None
        self._opened: dict[object, Channel] = {}

    async def start(self, tunnel: Tunnel) -> None:
        self.tunnel = tunnel
        self._ws = await serve(self._relay, "127.0.0.1", self.rosbridge_port, process_request=self._open_session,
                               max_size=self.max_size, compression=None, ping_interval=None)
        app = web.Application()
        app.router.add_get("/stream", self._http_get)
        app.router.add_get("/snapshot", self._http_get)
        self._http = web.AppRunner(app, access_log=None, handle_signals=False, shutdown_timeout=0.5)
        await self._http.setup()
        await web.TCPSite(self._http, "127.0.0.1", self.video_port).start()

    async def stop(self) -> None:
        self.tunnel = None
        if self._ws is not None:
            self._ws.close()
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(self._ws.wait_closed(), 2)
            self._ws = None
        if self._http is not None:
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(self._http.cleanup(), 2)
            self._http = None

    # --- rosbridge ----------------------------------------------------------------------

    async def _open_session(self, connection: ServerConnection, request: Request) -> Response | None:
        """The robot's rosbridge must be there before the handshake completes: "ready" means ready."""
        tunnel = self.tunnel
        if tunnel is None:
            return connection.respond(503, "the robot's uplink is not connected\n")
        try:
            channel = await tunnel.open({"kind": "rosbridge"})
            await channel.expect(mux.OPENED)
        except (ChannelClosed, ConnectionClosed) as exc:
            return connection.respond(502, f"the robot's rosbridge: {exc}\n")
        self._opened[connection] = channel
        return None

    async def _relay(self, connection: ServerConnection) -> None:
        channel = self._opened.pop(connection)
        from_robot = spawn(self._to_link(channel, connection))
        try:
            while True:
                message = await connection.recv(decode=False)
                await channel.send(message if isinstance(message, bytes) else message.encode())
        except (ConnectionClosed, ChannelClosed):
            pass
        finally:
            from_robot.cancel()
            channel.close("the server's rosbridge session closed")
            await connection.close()

    async def _to_link(self, channel: Channel, connection: ServerConnection) -> None:
        try:
            while True:
                kind, payload = await channel.next()
                if kind != mux.DATA:
                    why = payload.decode(errors="replace")[:100] or "the robot closed the session"
                    await connection.close(1011, why)
                    return
                await connection.send(payload, text=True)
        except (ConnectionClosed, ChannelClosed):
            pass  # either side gone: _relay ends the session

    # --- video --------------------------------------------------------------------------

    async def _http_get(self, request: web.Request) -> web.StreamResponse:
        tunnel = self.tunnel
        if tunnel is None:
            raise web.HTTPServiceUnavailable(text="the robot's uplink is not connected")
        try:
            channel = await tunnel.open({"kind": "http", "path": request.path, "query": request.query_string})
            head = mux.decode_json(await channel.expect(mux.HEAD))
        except (ChannelClosed, ConnectionClosed, ValueError) as exc:
            raise web.HTTPBadGateway(text=f"the robot's video server: {exc}") from None
        response = web.StreamResponse(status=int(head.get("status") or 502))
        headers = head.get("headers") or {}
        response.headers["Content-Type"] = str(headers.get("Content-Type") or "application/octet-stream")
        if str(headers.get("Content-Length") or "").isdigit():
            response.content_length = int(headers["Content-Length"])
        try:
            await response.prepare(request)
            while True:
                kind, payload = await channel.next()
                if kind != mux.DATA:
                    break
                await response.write(payload)
        finally:
            channel.close("the viewer left")
        return response
