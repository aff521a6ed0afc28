"""Run a SimRobot in a daemon thread with its own event loop (tests, benches, notebooks).

    with SimThread(port=0, startup_s=0.5) as sim:
        ros = roslibpy.Ros(sim.host, sim.port) ...
        sim.subscription_count("/cmd_vel"); sim.call(lambda: sim.robot.controller.fire("restart"))
"""

from __future__ import annotations

import asyncio
import threading
from collections.abc import Callable
from typing import Any, TypeVar

from .robot import SimRobot

T = TypeVar("T")


class SimThread:
    def __init__(self, **kwargs: Any) -> None:
        kwargs.setdefault("port", 0)
        kwargs.setdefault("video_port", 0)
        self.robot = SimRobot(**kwargs)
        self.loop: asyncio.AbstractEventLoop | None = None
        self._thread: threading.Thread | None = None
        self._ready = threading.Event()
        self._stopped = asyncio.Event()  # bound to the simulator's loop when first awaited there
        self._error: BaseException | None = None

    # --- lifecycle -------------------------------------------------------------------

    def start(self, timeout: float = 30.0) -> SimThread:
        self._thread = threading.Thread(target=asyncio.run, args=(self._main(),), name=f"simulator-{id(self):x}",
                                        daemon=True)
        self._thread.start()
        if not self._ready.wait(timeout):
            raise TimeoutError("simulator did not start")
        if self._error is not None:
            raise RuntimeError("simulator failed to start") from self._error
        return self

    async def _main(self) -> None:
        self.loop = asyncio.get_running_loop()
        try:
            await self.robot.start()
        except BaseException as exc:
            self._error = exc
            return
        finally:
            self._ready.set()
        await self._stopped.wait()
        await self.robot.stop()

    def stop(self, timeout: float = 10.0) -> None:
        if self.loop is None or self._thread is None or not self._thread.is_alive():
            return
        self.loop.call_soon_threadsafe(self._stopped.set)
        self._thread.join(timeout)

    def __enter__(self) -> SimThread:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    # --- access from other threads ---------------------------------------------------

    def call(self, fn: Callable[[], T], timeout: float = 10.0) -> T:
        """Run ``fn()`` on the simulator's loop and return its result."""
        assert self.loop is not None

        async def run() -> T:
            return fn()

        return asyncio.run_coroutine_threadsafe(run(), self.loop).result(timeout)

    @property
    def host(self) -> str:
        return self.robot.host

    @property
    def port(self) -> int:
        return self.robot.port

    @property
    def video_port(self) -> int:
        return self.robot.video_port

    @property
    def url(self) -> str:
        return self.robot.url

    @property
    def video_url(self) -> str:
        return f"http://{self.robot.host}:{self.robot.video_port}"

    def subscription_count(self, topic_name: str) -> int:
        return self.call(lambda: self.robot.subscription_count(topic_name))

    def received(self, topic_name: str) -> list[dict[str, Any]]:
        return self.call(lambda: self.robot.received(topic_name))

    def received_count(self, topic_name: str) -> int:
        return self.call(lambda: self.robot.received_count(topic_name))

    def snapshot(self) -> dict[str, Any]:
        return self.call(self.robot.snapshot)
