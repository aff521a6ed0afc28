"""One upstream camera stream however many people watch.

The robot's web_video_server encodes a JPEG stream per connection on a weak computer, so the
server holds ONE upstream MJPEG stream per (topic, width, height, quality) and hands every
viewer of it the newest frame. Each viewer has a one-frame slot (latest wins): a slow viewer
skips frames and never delays the others or the upstream. The upstream closes when its last
viewer leaves.

HTTP and the multipart stream are parsed by aiohttp (its C-accelerated parser and
``MultipartReader``), not by hand.
"""

from __future__ import annotations

import asyncio
import logging
import weakref
from dataclasses import dataclass, field
from typing import Any

import aiohttp
from django.conf import settings

from robot.supervisor import spawn

log = logging.getLogger(__name__)

CONNECT_TIMEOUT_S = 3.0
# A stream that sends nothing for this long is dead; the page reconnects.
READ_TIMEOUT_S = 10.0
TIMEOUT = aiohttp.ClientTimeout(total=None, sock_connect=CONNECT_TIMEOUT_S, sock_read=READ_TIMEOUT_S)
MAX_FRAME_BYTES = 10 * 1024 * 1024
BOUNDARY = "boundarydonotcross"
CONTENT_TYPE = f"multipart/x-mixed-replace;boundary={BOUNDARY}"

StreamKey = tuple[tuple[str, str], ...]  # the upstream's query parameters, sorted


class UpstreamError(Exception):
    pass


def encode_part(jpeg: bytes, headers: dict[str, str]) -> bytes:
    """One multipart part, encoded once and written as is to every viewer."""
    stamp = headers.get("X-Timestamp")
    head = f"--{BOUNDARY}\r\nContent-Type: image/jpeg\r\nContent-Length: {len(jpeg)}\r\n"
    if stamp:
        head += f"X-Timestamp: {stamp}\r\n"
    return head.encode() + b"\r\n" + jpeg + b"\r\n"


@dataclass(eq=False)
class Viewer:
    """A viewer's latest-value slot: ``None`` in ``frame`` after ``ended`` means the stream is over."""

    key: StreamKey
    person: object = None
    frame: bytes | None = None
    ended: bool = False
    ready: asyncio.Event = field(default_factory=asyncio.Event)

    def offer(self, part: bytes) -> None:
        self.frame = part  # an unread older frame is simply replaced: the viewer skips it
        self.ready.set()

    def end(self) -> None:
        self.ended = True
        self.ready.set()

    async def next(self) -> bytes | None:
        await self.ready.wait()
        if not self.ended:
            self.ready.clear()
        part, self.frame = self.frame, None
        return part


class Upstream:
    """One MJPEG connection to the video server and the viewers it feeds."""

    def __init__(self, base_url: str, params: StreamKey) -> None:
        self.base_url = base_url.rstrip("/")
        self.params = params
        self.viewers: set[Viewer] = set()
        self.opened: asyncio.Future[None] = asyncio.get_running_loop().create_future()
        self.frames = 0
        self.task = spawn(self._run())

    async def _run(self) -> None:
        try:
            async with aiohttp.ClientSession(timeout=TIMEOUT) as session:
                async with session.get(f"{self.base_url}/stream", params=list(self.params)) as response:
                    if response.status != 200 or not response.content_type.startswith("multipart/"):
                        raise UpstreamError(f"video server answered {response.status} {response.content_type}")
                    self.opened.set_result(None)
                    await self._pump(aiohttp.MultipartReader(response.headers, response.content))
        except asyncio.CancelledError:
            raise
        except (aiohttp.ClientError, TimeoutError, UpstreamError, ValueError) as exc:
            reason = str(exc) or type(exc).__name__
            if not self.opened.done():
                self.opened.set_exception(UpstreamError(f"video server unreachable: {reason}"))
            else:
                log.info("camera stream %s ended: %s", dict(self.params), reason)
        finally:
            if not self.opened.done():
                self.opened.set_exception(UpstreamError("video stream closed"))
            for viewer in self.viewers:
                viewer.end()

    async def _pump(self, reader: aiohttp.MultipartReader) -> None:
        while True:
            part = await reader.next()
            if part is None:
                return
            if not isinstance(part, aiohttp.BodyPartReader):
                raise UpstreamError("nested multipart in a camera stream")
            jpeg = await part.read()
            if len(jpeg) > MAX_FRAME_BYTES:
                raise UpstreamError(f"a {len(jpeg)}-byte frame")
            encoded = encode_part(bytes(jpeg), dict(part.headers))
            self.frames += 1
            for viewer in self.viewers:
                viewer.offer(encoded)

    def close(self) -> None:
        self.task.cancel()


# A request for a size or quality nobody else watches opens a stream on the robot's video server;
# past this many in a process, it shares the camera's own size instead (each costs the robot an encoder).
MAX_UPSTREAMS = 4
SIZE_PARAMS = ("width", "height", "quality")


class TooManyStreams(Exception):
    pass


@dataclass(eq=False)
class VideoRelay:
    """The upstream streams of one event loop, keyed by their parameters."""

    upstreams: dict[StreamKey, Upstream] = field(default_factory=dict)

    def viewers(self, person: object = None) -> int:
        return sum(1 for upstream in self.upstreams.values() for viewer in upstream.viewers
                   if person is None or viewer.person == person)

    async def join(self, base_url: str, params: dict[str, Any], *, person: object = None) -> Viewer:
        """Join (or open) the upstream for ``params``; UpstreamError when the video server is down,
        TooManyStreams past ``CAMERA_STREAMS_PER_PERSON`` or ``CAMERA_STREAMS_TOTAL`` in this process."""
        if self.viewers() >= settings.CAMERA_STREAMS_TOTAL:
            raise TooManyStreams(f"this server already streams the camera {settings.CAMERA_STREAMS_TOTAL} times")
        if person is not None and self.viewers(person) >= settings.CAMERA_STREAMS_PER_PERSON:
            raise TooManyStreams(f"you already watch the camera {settings.CAMERA_STREAMS_PER_PERSON} times: "
                                 "close a page or tab that shows it")
        key: StreamKey = tuple(sorted((k, str(v)) for k, v in params.items()))
        if key not in self.upstreams and len(self.upstreams) >= MAX_UPSTREAMS:
            key = tuple((k, v) for k, v in key if k not in SIZE_PARAMS)
        upstream = self.upstreams.get(key)
        if upstream is None or upstream.task.done():
            upstream = self.upstreams[key] = Upstream(base_url, key)
        viewer = Viewer(key, person)
        upstream.viewers.add(viewer)
        try:
            await asyncio.shield(upstream.opened)
        except BaseException:
            self.leave(viewer)
            raise
        return viewer

    def leave(self, viewer: Viewer) -> None:
        """Idempotent; the upstream closes with its last viewer."""
        upstream = self.upstreams.get(viewer.key)
        if upstream is None or viewer not in upstream.viewers:
            return
        upstream.viewers.discard(viewer)
        if not upstream.viewers:
            upstream.close()
            del self.upstreams[viewer.key]


_relays: weakref.WeakKeyDictionary[asyncio.AbstractEventLoop, VideoRelay] = weakref.WeakKeyDictionary()


def get_relay() -> VideoRelay:
    return _relays.setdefault(asyncio.get_running_loop(), VideoRelay())


async def fetch_snapshot(base_url: str, params: dict[str, Any]) -> tuple[bytes, str]:
    """One JPEG (body, content type); UpstreamError when the video server is down or the reply is bad."""
    query = [(k, str(v)) for k, v in params.items()]
    try:
        async with aiohttp.ClientSession(timeout=TIMEOUT) as session:
            async with session.get(f"{base_url.rstrip('/')}/snapshot", params=query) as response:
                if response.status != 200:
                    raise UpstreamError(f"video server answered {response.status}")
                if (response.content_length or 0) > MAX_FRAME_BYTES:
                    raise UpstreamError(f"a {response.content_length}-byte snapshot")
                body = bytearray()
                async for chunk in response.content.iter_chunked(64 * 1024):
                    body += chunk
                    if len(body) > MAX_FRAME_BYTES:
                        raise UpstreamError(f"a snapshot over {MAX_FRAME_BYTES} bytes")
                if not body or (response.content_length is not None and len(body) != response.content_length):
                    raise UpstreamError(f"snapshot cut short ({len(body)} bytes)")
                return bytes(body), response.content_type or "image/jpeg"
    except (aiohttp.ClientError, TimeoutError) as exc:
        raise UpstreamError(f"video server unreachable: {str(exc) or type(exc).__name__}") from None
