"""The agent: keeps one uplink open and serves the channels the server opens over it."""

import asyncio
import logging
import random
import ssl
import time
from urllib.parse import urlsplit

from . import dial, mux, ws
from .safety import Deadman, Lateness, LocalGuard

log = logging.getLogger("uplink_agent")
HIGH_WATER = 64 * 1024  # bytes waiting for the uplink before a video pump waits (rosbridge never does)
CHUNK = 32 * 1024
LOCAL_TIMEOUT_S = 3.0


class Settings:
    def __init__(self, server_url, credential, rosbridge_url="ws://127.0.0.1:9090",
                 video_url="http://127.0.0.1:8080", cmd_vel_topic="/cmd_vel", deadman_s=0.4, ping_s=2.0,
                 silence_s=6.0, backoff_s=0.25, backoff_max_s=10.0, proxy_url="", ca_file="",
                 max_frame_bytes=64 * 1024 * 1024):
        if not credential:
            raise ValueError("no credential: set UPLINK_CREDENTIAL or UPLINK_CREDENTIAL_FILE")
        if not all(33 <= ord(c) < 127 for c in credential):
            raise ValueError("the credential holds spaces, line breaks or other characters no credential has")
        self.server_url = dial.check_server_url(server_url)
        self.credential = credential
        self.rosbridge_url = rosbridge_url
        self.video_url = video_url
        self.cmd_vel_topic = cmd_vel_topic
        self.deadman_s = deadman_s
        self.ping_s = ping_s
        self.silence_s = silence_s
        self.backoff_s = backoff_s
        self.backoff_max_s = backoff_max_s
        self.proxy_url = proxy_url
        self.ca_file = ca_file
        self.max_frame_bytes = max_frame_bytes


def backoff(attempt, base, cap):
    """Capped exponential backoff with jitter: many robots restarted together do not dial in step."""
    ceiling = min(cap, base * (2 ** min(attempt, 16)))
    return random.uniform(ceiling / 2, ceiling)


class Session:
    """One open uplink: its channels and its keepalive."""

    def __init__(self, agent, socket):
        self.agent = agent
        self.socket = socket
        self.channels = {}
        self.lateness = Lateness()
        self._drain_lock = asyncio.Lock()

    def send(self, kind, channel, payload=b""):
        self.socket.send_frame(ws.BINARY, mux.encode(kind, channel, payload))

    def send_json(self, kind, channel, value):
        self.socket.send_frame(ws.BINARY, mux.encode_json(kind, channel, value))

    async def drain(self, limit=0):
        """Wait until at most ``limit`` bytes wait for the uplink (one drain at a time: Python 3.5's rule)."""
        transport = self.socket.writer.transport
        if transport.get_write_buffer_size() <= limit:
            return
        async with self._drain_lock:
            await self.socket.drain()

    async def run(self):
        keepalive = asyncio.ensure_future(self._keepalive())
        try:
            while True:
                opcode, message = await self.socket.recv()
                if opcode == ws.BINARY:
                    self._dispatch(*mux.decode(message))
        finally:
            keepalive.cancel()
            for channel in list(self.channels.values()):
                channel.close()
            self.channels.clear()
            self.socket.close()

    def _dispatch(self, kind, cid, payload):
        if kind == mux.OPEN:
            request = mux.decode_json(payload)
            maker = {"rosbridge": RosbridgeChannel, "http": HttpChannel}.get(request.get("kind"))
            if maker is None or cid in self.channels:
                self.send(mux.CLOSE, cid, b"unknown channel kind or id in use")
                return
            channel = self.channels[cid] = maker(self, cid, request)
            channel.start()
        elif kind in (mux.DATA, mux.STAMPED):
            late = 0.0
            if kind == mux.STAMPED:
                stamp, payload = mux.split_stamp(payload)
                late = self.lateness.late(stamp)
            target = self.channels.get(cid)
            if target is not None:
                target.from_server(payload, late)
        elif kind == mux.CLOSE:
            ended = self.channels.pop(cid, None)
            if ended is not None:
                ended.close()

    def ended(self, cid, reason):
        if self.channels.pop(cid, None) is not None and not self.socket.closed:
            self.send(mux.CLOSE, cid, reason.encode())

    async def _keepalive(self):
        while True:
            await asyncio.sleep(self.agent.settings.ping_s)
            silent = time.monotonic() - self.socket.heard_at
            if silent > self.agent.settings.silence_s:
                log.warning("the server has been silent for %.1f s: dropping the uplink", silent)
                self.socket.writer.transport.abort()
                return
            self.socket.send_frame(ws.PING, b"")


class Channel:
    def __init__(self, session, cid, request):
        self.session = session
        self.cid = cid
        self.request = request
        self.task = None

    def start(self):
        self.task = asyncio.ensure_future(self._guarded())

    async def _guarded(self):
        reason = ""
        try:
            await self.run()
        except asyncio.CancelledError:
            return
        except (OSError, asyncio.TimeoutError, ws.Closed, ws.HandshakeError, ValueError) as exc:
            reason = str(exc) or type(exc).__name__
        except Exception as exc:
            log.exception("channel %d failed", self.cid)
            reason = "agent error: %s" % type(exc).__name__
        self.session.ended(self.cid, reason)
        self.cleanup()

    async def run(self):
        raise NotImplementedError

    def close(self):
        if self.task is not None:
            self.task.cancel()
        self.cleanup()

    def cleanup(self):
        pass

    def from_server(self, payload, late):
        pass


class RosbridgeChannel(Channel):
    """A rosbridge session to the robot's own rosbridge, message for message."""

    robot = None

    async def run(self):
        url = urlsplit(self.session.agent.settings.rosbridge_url)
        reader, writer = await asyncio.wait_for(
            asyncio.open_connection(url.hostname or "127.0.0.1", url.port or 9090), LOCAL_TIMEOUT_S)
        dial.nodelay(writer)
        self.robot = await asyncio.wait_for(
            ws.handshake(reader, writer, url.netloc, url.path or "/",
                         max_size=self.session.agent.settings.max_frame_bytes), LOCAL_TIMEOUT_S)
        self.session.send(mux.OPENED, self.cid)
        while True:
            _, message = await self.robot.recv()
            self.session.send(mux.DATA, self.cid, message)
            await self.session.drain(HIGH_WATER * 16)  # a burst (a map) may queue; never without bound

    def from_server(self, payload, late):
        if not self.session.agent.deadman.passes(payload, late):
            return
        if self.robot is not None and not self.robot.closed:
            self.robot.send_frame(ws.TEXT, payload)

    def cleanup(self):
        if self.robot is not None:
            self.robot.close()
            self.robot = None


class HttpChannel(Channel):
    """One GET to the robot's video server (a stream or a snapshot), its answer streamed back."""

    writer = None

    async def run(self):
        path, query = self.request.get("path"), self.request.get("query") or ""
        if path not in mux.HTTP_PATHS or "\r" in query or "\n" in query or " " in query:
            raise ValueError("not a video server request the agent makes")
        url = urlsplit(self.session.agent.settings.video_url)
        reader, self.writer = await asyncio.wait_for(
            asyncio.open_connection(url.hostname or "127.0.0.1", url.port or 80), LOCAL_TIMEOUT_S)
        target = path + ("?" + query if query else "")
        self.writer.write(("GET %s HTTP/1.0\r\nHost: %s\r\nConnection: close\r\n\r\n" % (target, url.netloc))
                          .encode("latin-1"))
        status, _, headers = await asyncio.wait_for(ws.read_head(reader), LOCAL_TIMEOUT_S)
        kept = {name: headers[name.lower()] for name in ("Content-Type", "Content-Length") if name.lower() in headers}
        self.session.send_json(mux.HEAD, self.cid, {"status": status, "headers": kept})
        while True:
            chunk = await reader.read(CHUNK)
            if not chunk:
                return
            self.session.send(mux.DATA, self.cid, chunk)
            await self.session.drain(HIGH_WATER)

    def cleanup(self):
        if self.writer is not None:
            self.writer.close()
            self.writer = None


class Agent:
    def __init__(self, settings):
        self.settings = settings
        self.guard = LocalGuard(settings.rosbridge_url, settings.cmd_vel_topic)
        self.deadman = None
        self.connected_at = None
        self.sessions = 0

    async def run(self):
        self.deadman = Deadman(self.settings.cmd_vel_topic, self.settings.deadman_s, self.guard)
        guard = asyncio.ensure_future(self.guard.run())
        attempt = 0
        try:
            while True:
                try:
                    socket = await dial.open_uplink(
                        self.settings.server_url, self.settings.credential, ca_file=self.settings.ca_file,
                        proxy_url=self.settings.proxy_url, max_size=self.settings.max_frame_bytes)
                except ws.HandshakeError as exc:
                    log.error("the server refused the uplink: %s", exc)
                    # A refused credential is not fixed by trying hard: wait the longest.
                    attempt = max(attempt, 16) if exc.status in (401, 403) else attempt
                except (OSError, asyncio.TimeoutError, ssl.SSLError, ws.Closed) as exc:
                    log.warning("cannot reach %s: %s", self.settings.server_url, str(exc) or type(exc).__name__)
                else:
                    attempt = 0
                    self.sessions += 1
                    self.connected_at = time.monotonic()
                    log.info("uplink open to %s", self.settings.server_url)
                    try:
                        await Session(self, socket).run()
                    except (ws.Closed, mux.BadFrame, OSError) as exc:
                        log.warning("uplink lost: %s", exc)
                    finally:
                        self.connected_at = None
                        self.deadman.stop("the uplink dropped")
                await asyncio.sleep(backoff(attempt, self.settings.backoff_s, self.settings.backoff_max_s))
                attempt += 1
        finally:
            self.deadman.stop("the agent is stopping")
            guard.cancel()
