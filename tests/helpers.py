"""Test helpers: wait for a condition with a deadline instead of sleeping; stand-ins for awkward calls."""

from __future__ import annotations

import asyncio
import concurrent.futures
import time
from collections.abc import Callable, Coroutine
from typing import Any

# How long a test waits for an outcome before it fails: meant for a loaded machine (another suite, a
# CPU hog), not for the product's latency, which the benches measure. A wait ends when the outcome is there.
DEADLINE_S = 15.0


def wait_until(
    predicate: Callable[[], Any], *, timeout: float = DEADLINE_S, interval: float = 0.02, what: str = ""
) -> Any:
    deadline = time.monotonic() + timeout
    while True:
        value = predicate()
        if value:
            return value
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout} s waiting for {what or predicate}")
        time.sleep(interval)


async def async_wait_until(
    predicate: Callable[[], Any], *, timeout: float = DEADLINE_S, interval: float = 0.02, what: str = ""
) -> Any:
    deadline = time.monotonic() + timeout
    while True:
        value = predicate()
        if value:
            return value
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout} s waiting for {what or predicate}")
        await asyncio.sleep(interval)


async def receive_until(communicator, predicate: Callable[[dict], bool], *, timeout: float = DEADLINE_S) -> dict:
    """Read frames from a websocket communicator until one matches."""
    deadline = time.monotonic() + timeout
    while True:
        remaining = deadline - time.monotonic()
        if remaining <= 0:
            raise AssertionError("no matching websocket frame arrived in time")
        frame = await receive_frame(communicator, timeout=remaining)
        if predicate(frame):
            return frame


async def receive_frame(communicator, *, timeout: float = DEADLINE_S) -> dict:
    """The next frame, with each update of a batched frame (``kind: updates``) as a frame of its own."""
    queued: list[dict] = communicator.__dict__.setdefault("_unbatched", [])
    if not queued:
        frame = await communicator.receive_json_from(timeout=timeout)
        if frame.get("kind") != "updates":
            return frame
        queued.extend({"kind": "update", **update} for update in frame["updates"])
    return queued.pop(0)


def ws_communicator(user, path: str = "/ws/live/"):
    """A communicator against the full ASGI application with ``user`` already authenticated."""
    from channels.testing import WebsocketCommunicator

    from server.asgi import application

    communicator = WebsocketCommunicator(
        application, path, headers=[(b"origin", b"http://127.0.0.1"), (b"host", b"127.0.0.1")]
    )
    if user is not None:
        communicator.scope["user"] = user
    return communicator


def run_coroutine[T](coro: Coroutine[Any, Any, T]) -> T:
    """``asyncio.run`` on a thread of its own: a test may share its thread with Playwright's sync API,
    whose event loop runs there for as long as the session's browser lives."""
    with concurrent.futures.ThreadPoolExecutor(1) as thread:
        return thread.submit(asyncio.run, coro).result()
