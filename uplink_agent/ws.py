"""A small RFC 6455 websocket client over asyncio streams: enough for the uplink and for rosbridge.

Frames are read whole (continuations joined), pings answered, and every frame heard is noted in
``heard_at`` so a caller can tell a silent peer from a quiet one.
"""

import asyncio
import base64
import hashlib
import os
import struct
import time

CONT, TEXT, BINARY, CLOSE, PING, PONG = 0, 1, 2, 8, 9, 10
_GUID = b"258EAFA5-E914-47DA-95CA-C5AB0DC85B11"
_MAX_HEADER_BYTES = 16384


class HandshakeError(Exception):
    def __init__(self, status, reason):
        Exception.__init__(self, "websocket handshake refused: %s %s" % (status, reason))
        self.status = status


class Closed(Exception):
    pass


def _mask(payload, key):
    if not payload:
        return payload
    n = len(payload)
    repeated = (key * (n // 4 + 1))[:n]
    return (int.from_bytes(payload, "big") ^ int.from_bytes(repeated, "big")).to_bytes(n, "big")


def encode_frame(opcode, payload, masked=True):
    head = bytearray([0x80 | opcode])
    n = len(payload)
    bit = 0x80 if masked else 0
    if n < 126:
        head.append(bit | n)
    elif n < 65536:
        head.append(bit | 126)
        head += struct.pack("!H", n)
    else:
        head.append(bit | 127)
        head += struct.pack("!Q", n)
    if not masked:
        return bytes(head) + payload
    key = os.urandom(4)
    return bytes(head) + key + _mask(payload, key)


class WebSocket:
    """One open websocket (client side). ``recv`` returns (opcode, payload) for data frames."""

    def __init__(self, reader, writer, max_size):
        self.reader = reader
        self.writer = writer
        self.max_size = max_size
        self.heard_at = time.monotonic()
        self.closed = False

    def send_frame(self, opcode, payload):
        """Write one frame without waiting (call ``drain`` to wait for the socket)."""
        if self.closed:
            raise Closed("websocket closed")
        self.writer.write(encode_frame(opcode, payload))

    async def drain(self):
        await self.writer.drain()

    async def send(self, opcode, payload):
        self.send_frame(opcode, payload)
        await self.writer.drain()

    async def _frame(self):
        head = await self.reader.readexactly(2)
        fin, opcode, n = head[0] & 0x80, head[0] & 0x0F, head[1] & 0x7F
        if n == 126:
            n = struct.unpack("!H", await self.reader.readexactly(2))[0]
        elif n == 127:
            n = struct.unpack("!Q", await self.reader.readexactly(8))[0]
        if n > self.max_size:
            raise Closed("a %d-byte frame is over the limit" % n)
        key = await self.reader.readexactly(4) if head[1] & 0x80 else None
        payload = await self.reader.readexactly(n)
        if key is not None:
            payload = _mask(payload, key)
        self.heard_at = time.monotonic()
        return bool(fin), opcode, payload

    async def recv(self):
        """The next text or binary message; Closed when the peer closes or the stream ends."""
        parts, kind = [], None  # type: list, object
        try:
            while True:
                fin, opcode, payload = await self._frame()
                if opcode == PING:
                    self.send_frame(PONG, payload)
                    continue
                if opcode == PONG:
                    continue
                if opcode == CLOSE:
                    if not self.closed:
                        try:
                            self.send_frame(CLOSE, payload[:2])
                        except Closed:
                            pass
                    self.closed = True
                    raise Closed("closed by the peer")
                if opcode != CONT:
                    kind, parts = opcode, []
                parts.append(payload)
                if sum(len(p) for p in parts) > self.max_size:
                    raise Closed("a message over the limit")
                if fin:
                    return kind, b"".join(parts)
        except (asyncio.IncompleteReadError, ConnectionError, OSError) as exc:
            self.closed = True
            raise Closed("connection lost: %s" % (exc or type(exc).__name__))

    def close(self, code=1000):
        if not self.closed:
            self.closed = True
            try:
                self.writer.write(encode_frame(CLOSE, struct.pack("!H", code)))
            except Exception:
                pass
        self.writer.close()


async def read_head(reader):
    """An HTTP response head: (status, reason, headers with lower-case names)."""
    try:
        raw = await reader.readuntil(b"\r\n\r\n")
    except (asyncio.IncompleteReadError, asyncio.LimitOverrunError):
        raise HandshakeError(0, "no answer")
    if len(raw) > _MAX_HEADER_BYTES:
        raise HandshakeError(0, "no answer")
    lines = raw.decode("latin-1").split("\r\n")
    parts = lines[0].split(" ", 2)
    if len(parts) < 2 or not parts[1].isdigit():
        raise HandshakeError(0, "not HTTP: %r" % lines[0][:80])
    headers = {}
    for line in lines[1:]:
        if ":" in line:
            name, value = line.split(":", 1)
            headers[name.strip().lower()] = value.strip()
    return int(parts[1]), parts[2] if len(parts) > 2 else "", headers


async def handshake(reader, writer, host, path, headers=None, max_size=64 * 1024 * 1024):
    """Upgrade an open stream to a websocket (client side)."""
    key = base64.b64encode(os.urandom(16))
    lines = ["GET %s HTTP/1.1" % path, "Host: %s" % host, "Upgrade: websocket", "Connection: Upgrade",
             "Sec-WebSocket-Key: %s" % key.decode(), "Sec-WebSocket-Version: 13"]
    for name, value in sorted((headers or {}).items()):
        lines.append("%s: %s" % (name, value))
    writer.write(("\r\n".join(lines) + "\r\n\r\n").encode("latin-1"))
    await writer.drain()
    status, reason, answer = await read_head(reader)
    if status != 101:
        raise HandshakeError(status, reason)
    expected = base64.b64encode(hashlib.sha1(key + _GUID).digest()).decode()
    if answer.get("sec-websocket-accept") != expected:
        raise HandshakeError(status, "wrong Sec-WebSocket-Accept")
    return WebSocket(reader, writer, max_size)
