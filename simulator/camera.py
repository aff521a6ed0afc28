"""web_video_server look-alike (MJPEG stream, snapshots) plus the simulator's introspection API.

Routes:
  GET  /stream?topic=T[&type=mjpeg&quality=Q&width=W&height=H]  multipart MJPEG, ~8 fps
  GET  /snapshot?topic=T[&quality=Q&width=W&height=H]           one JPEG
  GET  /sim/introspect                                            the simulator's snapshot() as JSON
  GET  /sim/received?topic=T&last=N                               {"count", "messages": [{"t", "msg"}]}
  POST /sim/publish  {"topic", "msg", "count"?}                   publish to the topic's subscribers
"""

from __future__ import annotations

import asyncio
import io
import json
import logging
import math
import time
from datetime import datetime
from functools import cached_property
from typing import Any, Protocol
from urllib.parse import parse_qs, urlsplit

import numpy as np
from PIL import Image, ImageDraw

from .world import Base, WorldMap

log = logging.getLogger("simulator.camera")

BOUNDARY = "boundarydonotcross"
FPS = 8.0
VIEW_M = (8.0, 6.0)  # metres of map shown around the robot


class CameraHost(Protocol):
    """What the camera needs of the simulator (``SimRobot``, which it must not import): what to draw,
    and the introspection its HTTP routes serve."""

    world: WorldMap
    base: Base

    def plan(self) -> list[tuple[float, float]]: ...

    def caption(self) -> str: ...

    def snapshot(self) -> dict[str, Any]: ...

    def received_count(self, topic_name: str) -> int: ...

    def received_with_times(self, topic_name: str, last: int | None = None) -> list[dict[str, Any]]: ...

    def publish_external(self, topic: str, msg: dict[str, Any], count: int = 1) -> int: ...


class Renderer:
    """A bird's-eye "camera": the map around the robot, the robot, its plan and a timestamp."""

    def __init__(self, robot: CameraHost) -> None:
        self.robot = robot
        self._cache: dict[tuple[int, int, int], tuple[float, bytes]] = {}

    @cached_property
    def map_image(self) -> Image.Image:
        g = self.robot.world.grid
        rgb = np.empty((*g.shape, 3), dtype=np.uint8)
        rgb[g == -1] = (90, 90, 110)
        rgb[g == 0] = (235, 235, 225)
        rgb[g > 0] = (30, 30, 30)
        return Image.fromarray(rgb[::-1])  # image rows run top-down, map rows bottom-up

    def frame(self, width: int = 640, height: int = 480, quality: int = 80) -> bytes:
        key = (width, height, quality)
        hit = self._cache.get(key)
        now = time.monotonic()
        if hit is not None and now - hit[0] < 1.0 / FPS / 2:
            return hit[1]
        data = self._render(width, height, quality)
        self._cache[key] = (now, data)
        return data

    def _render(self, width: int, height: int, quality: int) -> bytes:
        r = self.robot
        w = r.world
        b = r.base
        res = w.resolution
        cx = (b.x - w.origin_x) / res
        cy = w.height - (b.y - w.origin_y) / res
        hw, hh = VIEW_M[0] / res / 2, VIEW_M[1] / res / 2
        crop = self.map_image.crop((int(cx - hw), int(cy - hh), int(cx + hw), int(cy + hh)))
        img = crop.resize((width, height), Image.Resampling.NEAREST)
        draw = ImageDraw.Draw(img)
        sx, sy = width / (2 * hw), height / (2 * hh)

        def to_px(x: float, y: float) -> tuple[float, float]:
            px = ((x - w.origin_x) / res - (int(cx - hw))) * sx
            py = ((w.height - (y - w.origin_y) / res) - int(cy - hh)) * sy
            return px, py

        path = [to_px(x, y) for x, y in r.plan()]
        if len(path) > 1:
            draw.line(path, fill=(40, 120, 230), width=3)
        px, py = to_px(b.x, b.y)
        rad = 0.3 / res * sx
        draw.ellipse((px - rad, py - rad, px + rad, py + rad), fill=(220, 60, 40), outline=(0, 0, 0))
        draw.line((px, py, px + rad * 1.6 * math.cos(b.yaw), py - rad * 1.6 * math.sin(b.yaw)),
                  fill=(0, 0, 0), width=3)
        now = datetime.now().astimezone()
        stamp = f"{now:%Y-%m-%d %H:%M:%S}.{now.microsecond // 1000:03d} {now:%Z}"
        text = f"{stamp}  x={b.x:.2f} y={b.y:.2f} {r.caption()}"
        draw.rectangle((0, 0, width, 16), fill=(0, 0, 0))
        draw.text((4, 2), text, fill=(255, 255, 255))
        out = io.BytesIO()
        img.save(out, "JPEG", quality=max(1, min(95, quality)))
        return out.getvalue()


def _json(obj: Any, status: str = "200 OK") -> tuple[str, str, bytes]:
    return status, "application/json", json.dumps(obj).encode()


def _int(q: dict[str, list[str]], name: str, default: int) -> int:
    try:
        return int(q.get(name, [default])[0])
    except ValueError:
        return default


class VideoServer:
    def __init__(self, robot: CameraHost) -> None:
        self.robot = robot
        self.renderer = Renderer(robot)
        self.server: asyncio.Server | None = None
        self.port = 0
        self.writers: set[asyncio.StreamWriter] = set()
        self.streams = 0  # open MJPEG streams (benches check a relay holds one)

    async def start(self, host: str, port: int) -> None:
        self.server = await asyncio.start_server(self._handle, host, port, reuse_address=True)
        self.port = self.server.sockets[0].getsockname()[1]

    async def stop(self) -> None:
        if self.server is None:
            return
        self.server.close()
        for w in list(self.writers):
            w.transport.abort()
        try:
            await asyncio.wait_for(self.server.wait_closed(), 3.0)
        except TimeoutError:
            log.warning("video server did not close within 3 s")

    async def _handle(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        self.writers.add(writer)
        try:
            request = await asyncio.wait_for(reader.readuntil(b"\r\n\r\n"), 10.0)
            lines = request.decode("latin-1").split("\r\n")
            method, target, _ = [*lines[0].split(" "), "", ""][:3]
            headers = {k.strip().lower(): v.strip() for k, _, v in (ln.partition(":") for ln in lines[1:] if ln)}
            body = await reader.readexactly(max(0, int(headers.get("content-length") or 0)))
            url = urlsplit(target)
            await self._route(method, url.path, parse_qs(url.query), body, writer)
        except (asyncio.IncompleteReadError, asyncio.LimitOverrunError, TimeoutError, ConnectionError,
                asyncio.CancelledError):
            # Cancelled: the server stopping (a Ctrl-C), ended quietly. Nobody awaits this task, and asyncio's
            # stream callback on 3.12.1 asks a cancelled one for its exception and logs the CancelledError.
            pass
        except Exception:
            log.exception("video server request failed")
        finally:
            self.writers.discard(writer)
            writer.close()

    async def _route(self, method: str, path: str, q: dict[str, list[str]], body: bytes,
                     writer: asyncio.StreamWriter) -> None:
        if (method, path) == ("GET", "/stream") and q.get("type", ["mjpeg"])[0] == "mjpeg":
            await self._stream(writer, _int(q, "width", 640), _int(q, "height", 480), _int(q, "quality", 80))
            return
        status, ctype, data = await self._page(method, path, q, body)
        writer.write(
            f"HTTP/1.0 {status}\r\nServer: web_video_server (simulated)\r\nContent-Type: {ctype}\r\n"
            f"Content-Length: {len(data)}\r\nAccess-Control-Allow-Origin: *\r\nConnection: close\r\n\r\n"
            .encode() + data
        )
        await writer.drain()

    async def _page(self, method: str, path: str, q: dict[str, list[str]], body: bytes) -> tuple[str, str, bytes]:
        """(status, content type, body) of every route but a stream."""
        robot = self.robot
        if method == "GET" and path == "/stream":
            return "501 Not Implemented", "text/plain", b"only mjpeg is simulated\n"
        if method == "GET" and path == "/snapshot":
            jpeg = await asyncio.to_thread(self.renderer.frame, _int(q, "width", 640), _int(q, "height", 480),
                                           _int(q, "quality", 80))
            return "200 OK", "image/jpeg", jpeg
        if method == "GET" and path == "/sim/introspect":
            return _json(robot.snapshot())
        if method == "GET" and path == "/sim/received":
            topic = q.get("topic", [""])[0]
            return _json({"count": robot.received_count(topic),
                          "messages": robot.received_with_times(topic, _int(q, "last", 100))})
        if method == "POST" and path == "/sim/publish":
            try:
                req = json.loads(body or b"{}")
                return _json({"published": robot.publish_external(req["topic"], req.get("msg", {}),
                                                                  int(req.get("count", 1)))})
            except Exception as exc:  # a bench's malformed request: tell it why
                return _json({"error": str(exc)}, "400 Bad Request")
        return "404 Not Found", "text/plain", b"not found\n"

    async def _stream(self, writer: asyncio.StreamWriter, width: int, height: int, quality: int) -> None:
        writer.write(
            f"HTTP/1.0 200 OK\r\nServer: web_video_server (simulated)\r\nCache-Control: no-cache, no-store, "
            f"must-revalidate, pre-check=0, post-check=0, max-age=0\r\nPragma: no-cache\r\n"
            f"Access-Control-Allow-Origin: *\r\nConnection: close\r\n"
            f"Content-Type: multipart/x-mixed-replace;boundary={BOUNDARY}\r\n\r\n".encode()
        )
        self.streams += 1
        try:
            while True:
                jpeg = await asyncio.to_thread(self.renderer.frame, width, height, quality)
                writer.write(
                    f"--{BOUNDARY}\r\nContent-type: image/jpeg\r\nContent-Length: {len(jpeg)}\r\n"
                    f"X-Timestamp: {time.time():.6f}\r\n\r\n".encode() + jpeg + b"\r\n"
                )
                await writer.drain()
                await asyncio.sleep(1.0 / FPS)
        finally:
            self.streams -= 1
