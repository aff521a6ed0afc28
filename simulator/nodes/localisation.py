"""amcl's particle cloud (simulator/localisation.py)."""

from __future__ import annotations

import random

from robot import interface as ri

from .. import messages
from ..bus import Bus, SimNode
from ..localisation import ParticleCloud
from ..world import Base
from .shapes import pose


class LocalisationNode(SimNode):
    """amcl's particle cloud, published as AMCL does after each filter update."""

    names: tuple[str, ...] = ()  # the navigation node names /amcl
    publishes = ("particlecloud",)

    def __init__(self, body: Base, rng: random.Random, rate_hz: float = 2.0) -> None:
        self.body = body
        self.cloud = ParticleCloud(rng)
        self.rate_hz = rate_hz

    def start(self, bus: Bus) -> None:
        super().start(bus)
        bus.on("initialpose", lambda m: self.cloud.initial_pose())
        bus.each_tick(lambda now, dt: self.cloud.step(dt, moving=self.body.v != 0.0 or self.body.w != 0.0))
        bus.every(1.0 / self.rate_hz, self._publish, wanted="particlecloud")

    def _publish(self) -> None:
        b = self.body
        poses = [pose(x, y, yaw) for x, y, yaw in self.cloud.poses(b.x, b.y, b.yaw)]
        self.bus.publish("particlecloud", {"header": messages.header(ri.MAP_FRAME), "poses": poses})
