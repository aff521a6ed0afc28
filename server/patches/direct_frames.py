"""Daphne websockets that take pre-encoded frames: one ``send`` syscall per frame, no per-socket encode.

The live hub writes the same update frame to hundreds of sockets. Through ASGI each write costs
the session middleware's wrapper, Daphne's reply dispatch, autobahn's framing of the same text
again, and Twisted's buffered write: register the socket for writability, wait a loop turn,
``send``, unregister (two ``epoll_ctl`` calls per frame). A server's frames are not masked, so
one encoded frame serves every socket (``robot.live.frames.ws_text_frame``).

Daphne offers its websocket connections this as an ASGI scope extension, ``EXTENSION``:
``scope["extensions"][EXTENSION]["writer"]`` is a ``FrameWriter``. Consumers that find no such
extension (another server, the test communicator) send through ASGI as usual.
"""

from __future__ import annotations

import logging
from typing import Any

from robot.live.hub import FRAMES_EXTENSION as EXTENSION

log = logging.getLogger(__name__)


class FrameWriter:
    """Writes whole encoded frames to one Daphne websocket connection, in order with Twisted's writes."""

    __slots__ = ("_protocol",)

    def __init__(self, protocol: Any) -> None:
        self._protocol = protocol

    def _transport(self) -> Any:
        protocol = self._protocol
        if protocol.state != protocol.STATE_OPEN or protocol._perMessageCompress is not None:
            return None
        transport = protocol.transport
        if transport is None or not transport.connected or transport.disconnecting or transport._writeDisconnected:
            return None
        return transport

    def backlog(self) -> int:
        """Bytes written but not yet accepted by the kernel (a slow reader, or a closed socket: -1)."""
        transport = self._transport()
        if transport is None:
            return -1
        return len(transport.dataBuffer) - transport.offset + transport._tempDataLen

    def write(self, frame: bytes) -> bool:
        """Send one encoded frame; False when the connection is closing (nothing written).

        With Twisted's buffer empty the frame goes straight to the socket (one ``send``); whatever
        the kernel does not take now, and any frame behind buffered data, goes through Twisted.
        """
        transport = self._transport()
        if transport is None:
            return False
        if getattr(transport, "TLS", False) or transport.dataBuffer or transport._tempDataLen:
            transport.write(frame)
            return True
        try:
            sent = transport.socket.send(frame)
        except BlockingIOError:
            sent = 0
        except OSError:
            log.debug("direct frame write failed; Twisted will see the connection close", exc_info=True)
            return False
        if sent < len(frame):
            transport.write(frame[sent:])
        return True


def install() -> None:
    """Give every Daphne websocket connection's scope a ``FrameWriter``."""
    from daphne.server import Server
    from daphne.ws_protocol import WebSocketProtocol

    if getattr(Server.create_application, "_frame_writer", False):
        return
    create_application = Server.create_application

    def with_frame_writer(self: Server, protocol: Any, scope: dict[str, Any]) -> Any:
        if isinstance(protocol, WebSocketProtocol):
            scope = {**scope, "extensions": {**scope.get("extensions", {}),
                                             EXTENSION: {"writer": FrameWriter(protocol)}}}
        return create_application(self, protocol, scope)

    with_frame_writer._frame_writer = True  # type: ignore[attr-defined]
    Server.create_application = with_frame_writer
