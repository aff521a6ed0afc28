"""The robot's camera through the server: only logged-in users see it, and the browser never
talks to the video server (web_video_server on the robot's network).

The stream is relayed as it arrives by an async generator, so a long-lived MJPEG stream
holds no thread; when the client goes away Django cancels the generator and the upstream
connection closes with it.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import AsyncIterator
from dataclasses import dataclass
from urllib.parse import urlencode, urlsplit

from django.conf import settings
from django.http import HttpRequest, HttpResponse, StreamingHttpResponse

log = logging.getLogger(__name__)

CONNECT_TIMEOUT_S = 3.0
# A stream that sends nothing for this long is dead; the page reconnects.
READ_TIMEOUT_S = 10.0
MAX_SNAPSHOT_BYTES = 10 * 1024 * 1024
CHUNK = 64 * 1024
_SIZE_PARAMS = {"width": (16, 1920), "height": (16, 1080), "quality": (1, 100)}

PLACEHOLDER_SVG = (
    '<svg xmlns="http://www.w3.org/2000/svg" width="640" height="480" viewBox="0 0 640 480">'
    '<rect width="640" height="480" fill="#1b2230"/><text x="320" y="240" fill="#c7d0dd" font-family="sans-serif"'
    ' font-size="22" text-anchor="middle">Camera unavailable</text></svg>'
)


class UpstreamError(Exception):
    pass


@dataclass
class Upstream:
    reader: asyncio.StreamReader
    writer: asyncio.StreamWriter
    headers: dict[str, str]

    def close(self) -> None:
        self.writer.close()


async def _open(path: str, params: dict[str, str | int]) -> Upstream:
    """GET ``VIDEO_URL + path`` and read the response head; UpstreamError unless 200."""
    base = urlsplit(settings.VIDEO_URL)
    secure = base.scheme == "https"
    host = base.hostname or "127.0.0.1"
    port = base.port or (443 if secure else 80)
    try:
        reader, writer = await asyncio.wait_for(
            asyncio.open_connection(host, port, ssl=True if secure else None, limit=CHUNK), CONNECT_TIMEOUT_S
        )
    except (OSError, TimeoutError) as exc:
        raise UpstreamError(f"video server unreachable: {exc or type(exc).__name__}") from None
    target = f"{base.path.rstrip('/')}{path}?{urlencode(params)}"
    writer.write(f"GET {target} HTTP/1.0\r\nHost: {base.netloc}\r\nConnection: close\r\n\r\n".encode())
    try:
        head = await asyncio.wait_for(reader.readuntil(b"\r\n\r\n"), READ_TIMEOUT_S)
    except (OSError, TimeoutError, asyncio.IncompleteReadError, asyncio.LimitOverrunError) as exc:
        writer.close()
        raise UpstreamError(f"video server sent no response: {type(exc).__name__}") from None
    status_line, *lines = head.decode("latin-1").split("\r\n")
    parts = status_line.split(" ", 2)
    if len(parts) < 2 or parts[1] != "200":
        writer.close()
        raise UpstreamError(f"video server answered {status_line!r}")
    headers = {k.strip().lower(): v.strip() for k, _, v in (ln.partition(":") for ln in lines if ln)}
    return Upstream(reader, writer, headers)


async def _relay(upstream: Upstream) -> AsyncIterator[bytes]:
    try:
        while True:
            chunk = await asyncio.wait_for(upstream.reader.read(CHUNK), READ_TIMEOUT_S)
            if not chunk:
                return
            yield chunk
    except (OSError, TimeoutError):
        return
    finally:
        upstream.close()


def _params(request: HttpRequest, **fixed: str) -> dict[str, str | int]:
    params: dict[str, str | int] = {"topic": settings.VIDEO_TOPIC, **fixed}
    for name, (low, high) in _SIZE_PARAMS.items():
        raw = request.GET.get(name, "")
        if raw.isdigit():
            params[name] = max(low, min(high, int(raw)))
    return params


def _unavailable(reason: str) -> HttpResponse:
    log.info("camera unavailable: %s", reason)
    response = HttpResponse(PLACEHOLDER_SVG, status=503, content_type="image/svg+xml")
    response["Retry-After"] = "3"
    response["Cache-Control"] = "no-store"
    return response


async def video_stream(request: HttpRequest) -> HttpResponse:
    """MJPEG (multipart/x-mixed-replace) from the robot's camera; 503 + placeholder when it is down."""
    try:
        upstream = await _open("/stream", _params(request, type="mjpeg"))
    except UpstreamError as exc:
        return _unavailable(str(exc))
    content_type = upstream.headers.get("content-type", "multipart/x-mixed-replace;boundary=boundarydonotcross")
    response = StreamingHttpResponse(_relay(upstream), content_type=content_type)
    response["Cache-Control"] = "no-store"
    response["X-Accel-Buffering"] = "no"  # a proxy in front must not buffer an endless stream
    return response


async def video_snapshot(request: HttpRequest) -> HttpResponse:
    """One JPEG from the camera; 503 + placeholder when the video server is down."""
    try:
        upstream = await _open("/snapshot", _params(request))
    except UpstreamError as exc:
        return _unavailable(str(exc))
    try:
        body = b"".join([chunk async for chunk in _relay(upstream)])
    finally:
        upstream.close()
    length = upstream.headers.get("content-length", "")
    if not body or len(body) > MAX_SNAPSHOT_BYTES or (length.isdigit() and int(length) != len(body)):
        return _unavailable(f"snapshot cut short ({len(body)} bytes)")
    response = HttpResponse(body, content_type=upstream.headers.get("content-type", "image/jpeg"))
    response["Cache-Control"] = "no-store"
    return response
