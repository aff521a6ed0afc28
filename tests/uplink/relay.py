"""A TCP relay of our own between the agent and the server (no kernel netem on this machine): a delay
each way with jitter, order kept; ``frozen`` holds every byte until thawed; ``cut()`` drops every
connection. It runs on an event loop of its own thread, so a test's or a bench's loop may block."""

from __future__ import annotations

import asyncio
import random
import socket
import threading
import time


class LatencyRelay:
    def __init__(self, listen: tuple[str, int], target: tuple[str, int], *, delay_s: float = 0.0,
                 jitter_s: float = 0.0) -> None:
        self.listen, self.target = listen, target
        self.delay_s, self.jitter_s = delay_s, jitter_s
        self.frozen = False
        self.loop = asyncio.new_event_loop()
        self.writers: set[asyncio.StreamWriter] = set()
        self.thread = threading.Thread(target=self.loop.run_forever, daemon=True)
        self.thread.start()
        asyncio.run_coroutine_threadsafe(self._start(), self.loop).result(5)

    async def _start(self) -> None:
        self.server = await asyncio.start_server(self._serve, *self.listen)

    async def _serve(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        try:
            up_reader, up_writer = await asyncio.open_connection(*self.target)
        except OSError:
            writer.close()
            return
        for w in (writer, up_writer):
            w.get_extra_info("socket").setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            self.writers.add(w)
        await asyncio.gather(self._pipe(reader, up_writer), self._pipe(up_reader, writer), return_exceptions=True)
        for w in (writer, up_writer):
            self.writers.discard(w)
            w.close()

    async def _pipe(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        queue: asyncio.Queue[tuple[float, bytes]] = asyncio.Queue()

        async def deliver() -> None:
            while True:
                due, chunk = await queue.get()
                while self.frozen or time.monotonic() < due:
                    await asyncio.sleep(0.001 if not self.frozen else 0.01)
                writer.write(chunk)
                await writer.drain()

        sender = asyncio.ensure_future(deliver())
        last_due = 0.0
        try:
            while chunk := await reader.read(65536):
                delay = max(0.0, self.delay_s + random.uniform(-self.jitter_s, self.jitter_s))
                last_due = max(last_due, time.monotonic() + delay)  # a later chunk never overtakes
                queue.put_nowait((last_due, chunk))
            while not queue.empty():
                await asyncio.sleep(0.005)
        finally:
            sender.cancel()
            writer.close()

    def cut(self) -> None:
        def close_all() -> None:
            for w in list(self.writers):
                w.transport.abort()
        self.loop.call_soon_threadsafe(close_all)

    async def _shutdown(self) -> None:
        self.server.close()
        for w in list(self.writers):
            w.transport.abort()
        tasks = [t for t in asyncio.all_tasks() if t is not asyncio.current_task()]
        for task in tasks:
            task.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)

    def close(self) -> None:
        asyncio.run_coroutine_threadsafe(self._shutdown(), self.loop).result(5)
        self.loop.call_soon_threadsafe(self.loop.stop)
        self.thread.join(5)
        self.loop.close()
