"""What the websocket server and the camera need from the simulator, as protocols.

``server.py`` and ``camera.py`` depend on these, not on ``robot.py``: ``SimRobot``
satisfies both, and builds the two servers, so imports run one way only.
"""

from __future__ import annotations

from typing import Any, Protocol

from .protocol import Broker
from .world import Base, WorldMap


class BridgeHost(Protocol):
    """The rosbridge server's view: the graph that clients' frames act on, and a hook for (dis)connects."""

    broker: Broker

    def client_connected(self) -> None: ...


class CameraHost(Protocol):
    """The camera's view: what to draw, and the introspection its HTTP routes serve."""

    world: WorldMap
    base: Base

    def plan(self) -> list[tuple[float, float]]: ...

    def caption(self) -> str: ...

    def snapshot(self) -> dict[str, Any]: ...

    def received_count(self, topic_name: str) -> int: ...

    def received_with_times(self, topic_name: str, last: int | None = None) -> list[dict[str, Any]]: ...

    def publish_external(self, topic: str, msg: dict[str, Any], count: int = 1) -> int: ...
