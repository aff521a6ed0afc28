"""The camera's way into history: one MJPEG stream from the video server at the recording size.

Every frame is offered to the recorder (``Recorder.offer_frame``), which keeps one every
1 / ``CAMERA_RECORD_FPS`` seconds for replay and every frame inside an incident's window, and
writes them with the messages. It runs wherever the link runs (a background service).

It reads the video server itself, not through the dashboard's relay (history sits below the
dashboard): the recording size is one more encoder on the robot's video server, however many
people watch.
"""

from __future__ import annotations

import asyncio
import logging
import time
from collections.abc import Callable
from typing import Any

import aiohttp
from django.conf import settings

from history.recorder import Recorder
from history.storage import FailureLog
from robot.supervisor import holding, running

log = logging.getLogger(__name__)

RECONNECT_S = 2.0
MAX_FRAME_BYTES = 10 * 1024 * 1024
CONNECT_TIMEOUT_S = 3.0
READ_TIMEOUT_S = 10.0


class CameraRecorder:
    def __init__(self, *, robot_connected: Callable[[], bool] = lambda: True) -> None:
        self.robot_connected = robot_connected  # no robot, no camera to read: nothing is asked of it
        self.received = self.lost = 0

    def offer(self, t: float, jpeg: bytes) -> None:
        self.received += 1
        if (recorder := running(Recorder)) is None:
            self.lost += 1
            return
        recorder.offer_frame(t, jpeg)

    async def pump_forever(self) -> None:
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
    if settings.CAMERA_RECORD_FPS <= 0:
        await asyncio.Event().wait()  # recording is off: idle until cancelled
    with holding(CameraRecorder(robot_connected=lambda: bool(link.connected))) as camera:
        await camera.pump_forever()
