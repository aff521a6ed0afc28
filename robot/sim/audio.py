"""The audio node: a text-to-speech queue and sound clip playback, with feedback topics."""

from __future__ import annotations

import asyncio
from collections.abc import Callable


class Audio:
    """Utterances play one after another; each one is reported (its text) on the feedback topic
    once it has been "spoken", after a time proportional to its length."""

    def __init__(self, spoken: Callable[[str], None], played: Callable[[str], None],
                 s_per_char: float = 0.03, min_s: float = 0.3, clip_s: float = 1.0) -> None:
        self.spoken = spoken
        self.played = played
        self.s_per_char = s_per_char
        self.min_s = min_s
        self.clip_s = clip_s
        self.queue: asyncio.Queue[str] = asyncio.Queue()
        self.speaking: str | None = None
        self.playing: str | None = None
        self.done_count = 0
        self._tasks: list[asyncio.Task[None]] = []

    def start(self) -> None:
        self._tasks.append(asyncio.get_running_loop().create_task(self._speak_loop()))

    def stop(self) -> None:
        for t in self._tasks:
            t.cancel()

    def duration(self, text: str) -> float:
        return max(self.min_s, self.s_per_char * len(text))

    def say(self, text: str) -> None:
        self.queue.put_nowait(text)

    def pending(self) -> list[str]:
        queued = list(self.queue._queue)  # type: ignore[attr-defined]  # read-only peek for introspection
        return ([self.speaking] if self.speaking is not None else []) + queued

    def play(self, clip: str) -> None:
        self.playing = clip
        task = asyncio.get_running_loop().create_task(self._play(clip))
        self._tasks = [t for t in self._tasks if not t.done()] + [task]

    async def _play(self, clip: str) -> None:
        await asyncio.sleep(self.clip_s)
        if self.playing == clip:
            self.playing = None
        self.played(clip)

    async def _speak_loop(self) -> None:
        while True:
            text = await self.queue.get()
            self.speaking = text
            await asyncio.sleep(self.duration(text))
            self.speaking = None
            self.done_count += 1
            self.spoken(text)
