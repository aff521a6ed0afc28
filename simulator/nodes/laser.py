"""RosAria's laser topic, ray-cast against the world (simulator/laser.py)."""

from __future__ import annotations

from functools import cached_property

from ..bus import Bus, SimNode
from ..laser import Laser
from ..world import Base, WorldMap


class LaserNode(SimNode):
    """RosAria's laser topic: a scan at ``rate_hz`` while anyone subscribes."""

    names: tuple[str, ...] = ()  # RosAria publishes it (the base node names /RosAria)
    publishes = ("scan",)

    def __init__(self, body: Base, world_map: WorldMap, rate_hz: float = 10.0) -> None:
        self.body = body
        self.world = world_map
        self.rate_hz = rate_hz

    def start(self, bus: Bus) -> None:
        super().start(bus)
        bus.every(1.0 / self.rate_hz, self._publish, wanted="scan")

    @cached_property
    def laser(self) -> Laser:
        """Built on first use: the distance map costs a moment."""
        return Laser(self.world)

    def _publish(self) -> None:
        b = self.body
        self.bus.publish("scan", self.laser.message(b.x, b.y, b.yaw, scan_time=1.0 / self.rate_hz))
