"""RosAria's laser topic, ray-cast against the world (robot/sim/laser.py)."""

from __future__ import annotations

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
        self._laser: Laser | None = None  # built on first use: the distance map costs a moment

    def start(self, bus: Bus) -> None:
        super().start(bus)
        bus.every(1.0 / self.rate_hz, self._publish, wanted="scan")

    @property
    def laser(self) -> Laser:
        if self._laser is None:
            self._laser = Laser(self.world)
        return self._laser

    def _publish(self) -> None:
        b = self.body
        msg = self.laser.message(b.x, b.y, b.yaw)
        msg["scan_time"] = 1.0 / self.rate_hz
        self.bus.publish("scan", msg)
