"""The camera recorder: one MJPEG stream from the video server at the recording size.

Every frame goes into a ring of the last ``INCIDENT_BEFORE_S`` seconds; one every
1 / ``CAMERA_RECORD_FPS`` seconds is kept for replay, and every frame inside an incident's
window (``hold``) is kept for the incident, including those already in the ring when the
incident began. Frames are written from a worker thread every ``HISTORY_FLUSH_S``; a clean
stop writes what it took. It runs wherever the link runs (a background service).

It reads the video server itself, not through the dashboard's relay (history sits below the
dashboard): the recording size is one more encoder on the robot's video server, however many
people watch.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Callable, Sequence
from typing import Any

import aiohttp
from django.conf import settings

from history.capture import Capture
from history.frames import Frame, write_frames
from history.storage import FailureLog
from robot.supervisor import holding

log = logging.getLogger(__name__)

RECONNECT_S = 2.0
MAX_FRAME_BYTES = 10 * 1024 * 1024
CONNECT_TIMEOUT_S = 3.0
READ_TIMEOUT_S = 10.0


class CameraRecorder(Capture[Frame]):
    def __init__(self, *, writer: Callable[[Sequence[Frame]], int] = write_frames, fps: float | None = None,
                 robot_connected: Callable[[], bool] = lambda: True) -> None:
        super().__init__(writer, "writing camera frames")
        self.robot_connected = robot_connected  # no robot, no camera to read: nothing is asked of it
        self.fps = settings.CAMERA_RECORD_FPS if fps is None else fps
        self._last_kept = 0.0

    def offer(self, t: float, jpeg: bytes) -> None:
        entry = self._remember(t, jpeg)
        incident = self._incident_at(t)
        if incident is not None:
            self._keep(entry, incident)
        elif self.fps > 0 and t - self._last_kept >= 1.0 / self.fps * 0.95:
            self._keep(entry, None)

    def _keep(self, entry: list[Any], incident: int | None) -> None:
        entry[2] = True
        if incident is None:
            self._last_kept = entry[0]
        self._pending.append((entry[0], entry[1], incident))

    def hold(self, incident: int, start: float, end: float) -> None:
        """Keep every frame in [start, end] for ``incident``: those in the ring now and those to come."""
        self.windows[incident] = (start, end)
        for entry in self._unkept(start, end):
            self._keep(entry, incident)

    def _batch(self, pending: list[Frame]) -> list[Frame]:
        return sorted(pending, key=lambda f: f[0])

    async def run(self) -> None:
        try:
            async with asyncio.TaskGroup() as group:
                group.create_task(self._pump_forever())
                while True:
                    await asyncio.sleep(settings.HISTORY_FLUSH_S)
                    await self.flush()
        finally:
            await self.flush()  # a clean stop loses nothing it took

    async def _pump_forever(self) -> None:
        failures = FailureLog("reading the camera for recording")
        while True:
            if self.robot_connected():
                try:
                    await self._pump()
                    failures.ok()
                except asyncio.CancelledError:
                    raise
                except (aiohttp.ClientError, TimeoutError, ValueError, OSError) as exc:
                    failures.failed(reason=str(exc) or type(exc).__name__)
            await asyncio.sleep(RECONNECT_S)

    async def _pump(self) -> None:
        params = {"topic": settings.VIDEO_TOPIC, "type": "mjpeg", "width": settings.CAMERA_RECORD_WIDTH,
                  "height": settings.CAMERA_RECORD_HEIGHT, "quality": settings.CAMERA_RECORD_QUALITY}
        timeout = aiohttp.ClientTimeout(total=None, sock_connect=CONNECT_TIMEOUT_S, sock_read=READ_TIMEOUT_S)
        url = f"{settings.VIDEO_URL.rstrip('/')}/stream"
        async with aiohttp.ClientSession(timeout=timeout) as session:
            async with session.get(url, params={k: str(v) for k, v in params.items()}) as response:
                if response.status != 200 or not response.content_type.startswith("multipart/"):
                    raise ValueError(f"video server answered {response.status} {response.content_type}")
                reader = aiohttp.MultipartReader(response.headers, response.content)
                while (part := await reader.next()) is not None:
                    if not isinstance(part, aiohttp.BodyPartReader):
                        raise ValueError("nested multipart in a camera stream")
                    jpeg = await part.read()
                    if len(jpeg) <= MAX_FRAME_BYTES:
                        # Receive time on the server's clock, like every recorded message.
                        self.offer(time.time(), bytes(jpeg))


async def run_camera_recorder(link: Any) -> None:
    """The background service registered in ``HistoryConfig.ready``."""
    camera = CameraRecorder(robot_connected=lambda: bool(link.connected))
    if camera.fps <= 0:
        await asyncio.Event().wait()  # recording is off: idle until cancelled
    with holding(camera):
        await camera.run()
