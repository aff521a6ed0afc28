"""Helpers for the audio socket tests: connect, read text and binary frames, talk a tone."""

from __future__ import annotations

import asyncio
import json
import time
from collections.abc import Callable
from typing import Any

from simulator.nodes.audiovisual import tone
from tests.helpers import DEADLINE_S, ws_communicator

TALK = {"type": "talk", "on": True, "format": "S16LE", "rate": 16000, "channels": 1}
CHUNK = 320  # samples: 20 ms at 16 kHz


class Frames:
    """One audio socket's frames, text (decoded) and binary, in order."""

    def __init__(self, communicator: Any) -> None:
        self.ws = communicator
        self.texts: list[dict[str, Any]] = []
        self.chunks: list[bytes] = []

    async def read(self, timeout: float = DEADLINE_S) -> None:
        message = await self.ws.receive_output(timeout)
        if message["type"] == "websocket.close":
            raise AssertionError(f"socket closed: {message}")
        if message.get("bytes") is not None:
            self.chunks.append(message["bytes"])
        else:
            self.texts.append(json.loads(message["text"]))

    async def text(self, match: Callable[[dict[str, Any]], bool], timeout: float = DEADLINE_S) -> dict[str, Any]:
        """The first text frame (seen before or arriving within ``timeout``) that matches; consumed."""
        deadline = time.monotonic() + timeout
        while True:
            for i, frame in enumerate(self.texts):
                if match(frame):
                    return self.texts.pop(i)
            left = deadline - time.monotonic()
            if left <= 0:
                raise AssertionError(f"no matching frame; got {self.texts[-5:]}")
            await self.read(left)

    async def chunk_count(self, count: int, timeout: float = DEADLINE_S) -> None:
        deadline = time.monotonic() + timeout
        while len(self.chunks) < count:
            left = deadline - time.monotonic()
            if left <= 0:
                raise AssertionError(f"only {len(self.chunks)} of {count} microphone chunks arrived")
            await self.read(left)

    async def send(self, content: dict[str, Any]) -> None:
        await self.ws.send_to(text_data=json.dumps(content))

    async def close(self) -> None:
        # Leaving gives back the lease and audits: let it finish on a loaded machine.
        await self.ws.disconnect(timeout=5)


async def audio_socket(user) -> Frames:
    """A connected ``/ws/audio/`` socket that has read its hello frame."""
    ws = ws_communicator(user, "/ws/audio/")
    connected, _ = await ws.connect(timeout=5)
    assert connected
    frames = Frames(ws)
    await frames.text(lambda f: f["type"] == "hello")
    return frames


def kind(name: str, **fields: Any) -> Callable[[dict[str, Any]], bool]:
    return lambda f: f["type"] == name and all(f.get(k) == v for k, v in fields.items())


async def talk_tone(frames: Frames, freq_hz: float, seconds: float, *, start: int = 0) -> int:
    """Send ``seconds`` of a tone in 20 ms chunks at real-time pace; return the next sample index."""
    loop = asyncio.get_running_loop()
    due = loop.time()
    n = start
    for _ in range(round(seconds / 0.02)):
        await frames.ws.send_to(bytes_data=tone(freq_hz, n, CHUNK, 16000))
        n += CHUNK
        due += 0.02
        await asyncio.sleep(max(0.0, due - loop.time()))
    return n
