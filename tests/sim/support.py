"""Helpers for the simulator tests: message inboxes, a raw rosbridge client, polling."""

from __future__ import annotations

import contextlib
import json
import queue
import threading
import time
from collections.abc import Callable
from typing import Any

import roslibpy
from websockets.sync.client import ClientConnection, connect

from tests.helpers import DEADLINE_S, wait_until

# State timers short enough for a fast suite.
FAST = dict(startup_s=0.3, demo_s=1.0, behaviour_s=0.4, tts_s_per_char=0.01, tts_min_s=0.1, clip_s=0.2,
            nav_speed=1.0, commander_pause_s=0.1)


class Inbox:
    """Collects messages from a roslibpy callback (reactor thread) for the test thread."""

    def __init__(self) -> None:
        self.items: list[Any] = []
        self.times: list[float] = []
        self._cond = threading.Condition()

    def __call__(self, msg: Any) -> None:
        with self._cond:
            self.items.append(msg)
            self.times.append(time.time())
            self._cond.notify_all()

    def wait(self, predicate: Callable[[list[Any]], Any] = bool, timeout: float = DEADLINE_S, what: str = "") -> Any:
        deadline = time.monotonic() + timeout
        with self._cond:
            while True:
                value = predicate(self.items)
                if value:
                    return value
                left = deadline - time.monotonic()
                if left <= 0:
                    raise AssertionError(f"timed out waiting for {what or predicate}; got {self.items[-5:]}")
                self._cond.wait(left)

    def wait_for(self, match: Callable[[Any], bool], timeout: float = DEADLINE_S, what: str = "") -> Any:
        return self.wait(lambda items: next((m for m in items if match(m)), None), timeout, what)

    def __len__(self) -> int:
        with self._cond:
            return len(self.items)


def subscribe(ros: roslibpy.Ros, name: str, msg_type: str, **kwargs: Any) -> Inbox:
    inbox = Inbox()
    roslibpy.Topic(ros, name, msg_type, **kwargs).subscribe(inbox)
    return inbox


class Raw:
    """A bare rosbridge client: JSON frames over a websocket, read by a background thread."""

    def __init__(self, url: str) -> None:
        self._stack = contextlib.ExitStack()
        self.ws: ClientConnection = self._stack.enter_context(connect(url, compression=None, open_timeout=5))
        self.frames: queue.Queue[dict[str, Any]] = queue.Queue()
        self.closed = threading.Event()
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        try:
            for raw in self.ws:
                self.frames.put(json.loads(raw))
        except Exception:
            pass
        finally:
            self.closed.set()

    def send(self, frame: dict[str, Any] | str) -> None:
        self.ws.send(frame if isinstance(frame, str) else json.dumps(frame))

    def expect(self, match: Callable[[dict[str, Any]], bool], timeout: float = DEADLINE_S) -> dict[str, Any]:
        deadline = time.monotonic() + timeout
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                raise AssertionError("expected frame did not arrive")
            try:
                frame = self.frames.get(timeout=left)
            except queue.Empty:
                continue
            if match(frame):
                return frame

    def collect(self, duration: float, match: Callable[[dict[str, Any]], bool] = lambda f: True) -> list[dict]:
        deadline = time.monotonic() + duration
        out = []
        while (left := deadline - time.monotonic()) > 0:
            try:
                frame = self.frames.get(timeout=left)
            except queue.Empty:
                break
            if match(frame):
                out.append(frame)
        return out

    def call(self, service: str, args: Any = None, cid: str = "c1", timeout: float = DEADLINE_S) -> dict[str, Any]:
        frame: dict[str, Any] = {"op": "call_service", "service": service, "id": cid}
        if args is not None:
            frame["args"] = args
        self.send(frame)
        return self.expect(lambda f: f.get("op") == "service_response" and f.get("id") == cid, timeout)

    def close(self) -> None:
        self._stack.close()


def on_topic(topic: str) -> Callable[[dict[str, Any]], bool]:
    return lambda f: f.get("op") == "publish" and f.get("topic") == topic


__all__ = ["wait_until"]
