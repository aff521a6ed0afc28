"""The robot's camera through the server: only logged-in users see it, and the browser never
talks to the video server (web_video_server on the robot's network).

Every viewer of the same (topic, size, quality) shares one upstream stream (dashboard.videorelay);
the response is an async generator, so a long-lived MJPEG stream holds no thread, and when the
client goes away Django cancels it and the viewer leaves the relay.
"""

from __future__ import annotations

import logging
import weakref
from collections.abc import AsyncIterator
from typing import Any

from django.conf import settings
from django.http import HttpRequest, HttpResponse, HttpResponseBase, StreamingHttpResponse
from django.utils.html import escape

from dashboard.revocation import end_when_revoked
from dashboard.videorelay import (
    CONTENT_TYPE,
    TooManyStreams,
    UpstreamError,
    VideoRelay,
    Viewer,
    fetch_snapshot,
    get_relay,
)
from robot.supervisor import spawn

log = logging.getLogger(__name__)

# Sizes and qualities a page may ask for: any other is snapped to the nearest of these (each
# distinct one would cost the robot an encoder).
SIZES = {"width": (320, 640, 1280), "height": (240, 480, 720), "quality": (30, 50, 80)}

PLACEHOLDER_SVG = (
    '<svg xmlns="http://www.w3.org/2000/svg" width="640" height="480" viewBox="0 0 640 480">'
    '<rect width="640" height="480" fill="#1b2230"/><text x="320" y="240" fill="#c7d0dd" font-family="sans-serif"'
    ' font-size="22" text-anchor="middle">Camera unavailable</text></svg>'
)


def _params(request: HttpRequest, **fixed: str) -> dict[str, str | int]:
    params: dict[str, str | int] = {"topic": settings.VIDEO_TOPIC, **fixed}
    for name, sizes in SIZES.items():
        raw = request.GET.get(name, "")
        if raw.isdigit() and len(raw) < 6:
            params[name] = min(sizes, key=lambda size: abs(size - int(raw)))
    return params


def _unavailable(reason: str, status: int = 503, text: str = "Camera unavailable", *,
                 image: bool = True) -> HttpResponse:
    """The placeholder picture; none (``image=False``) for a page that says it itself, so the
    picture's text and the page's never lie one over the other."""
    log.info("camera unavailable: %s", reason)
    response = (HttpResponse(PLACEHOLDER_SVG.replace("Camera unavailable", escape(text)), status=status,
                             content_type="image/svg+xml") if image
                else HttpResponse(text, status=status, content_type="text/plain; charset=utf-8"))
    response["Retry-After"] = "3"
    response["Cache-Control"] = "no-store"
    return response


async def _frames(relay: VideoRelay, viewer: Viewer, person: dict[str, Any]) -> AsyncIterator[bytes]:
    # The person's access changes (a logout, a deactivation, a new password): their streams end.
    revoked = spawn(end_when_revoked(person, operator=False, end=viewer.end))
    try:
        while (part := await viewer.next()) is not None:
            yield part
    finally:
        revoked.cancel()
        relay.leave(viewer)


async def video_stream(request: HttpRequest) -> HttpResponseBase:
    """MJPEG (multipart/x-mixed-replace) from the robot's camera; 503 + placeholder when it is down,
    429 past a person's or the server's number of streams (with ``fallback=none``, no placeholder)."""
    relay = get_relay()
    user = await request.auser()
    image = request.GET.get("fallback") != "none"  # the Drive page shows its own placeholder
    try:
        viewer = await relay.join(settings.VIDEO_URL, _params(request, type="mjpeg"), person=user.pk)
    except TooManyStreams as exc:
        return _unavailable(str(exc), 429, "Too many camera streams", image=image)
    except UpstreamError as exc:
        return _unavailable(str(exc), image=image)
    frames = _frames(relay, viewer, {"user": user, "session": request.session})
    # A client gone before the body started never runs the generator's finally.
    weakref.finalize(frames, relay.leave, viewer)
    response = StreamingHttpResponse(frames, content_type=CONTENT_TYPE)
    response["Cache-Control"] = "no-store"
    response["X-Accel-Buffering"] = "no"  # a proxy in front must not buffer an endless stream
    return response


async def video_snapshot(request: HttpRequest) -> HttpResponse:
    """One JPEG from the camera; 503 + placeholder when the video server is down."""
    try:
        body, content_type = await fetch_snapshot(settings.VIDEO_URL, _params(request))
    except UpstreamError as exc:
        return _unavailable(str(exc))
    response = HttpResponse(body, content_type=content_type)
    response["Cache-Control"] = "no-store"
    return response
