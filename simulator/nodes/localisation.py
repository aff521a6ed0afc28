"""amcl's particle cloud: spread around the true pose, wide after an initial pose, tightening.

Not a particle filter: the simulator knows where the robot is. Each particle keeps a fixed
random offset (in standard deviations) that is scaled by the current spread, so the cloud
shrinks smoothly toward ``MIN_SPREAD`` as scans come in, faster while the robot moves (AMCL
only updates after moving), and jumps wide again when an operator sets an initial pose.
"""

from __future__ import annotations

import math
import random

from robot import interface as ri

from .. import messages
from ..bus import Bus, SimNode
from ..world import Base, pose

# amcl's defaults: initial_cov_xx/yy 0.5 * 0.5 m^2, initial_cov_aa (pi/12)^2 rad^2.
INITIAL_SPREAD = (0.5, math.pi / 12)
MIN_SPREAD = (0.04, 0.02)
START_SPREAD = (1.5, 0.6)  # before anyone says where the robot is
TIGHTEN_S = 1.2  # time constant while the robot moves
TIGHTEN_IDLE_S = 4.0  # and while it stands (scans still come in)


class LocalisationNode(SimNode):
    """amcl's particle cloud, published as AMCL does after each filter update."""

    names: tuple[str, ...] = ()  # the navigation node names /amcl
    publishes = ("particlecloud",)

    def __init__(self, body: Base, rng: random.Random, rate_hz: float = 2.0, count: int = 300) -> None:
        self.body = body
        self.rng = rng
        self.rate_hz = rate_hz
        self.count = count
        self.spread_xy, self.spread_yaw = START_SPREAD
        self._draw()

    def start(self, bus: Bus) -> None:
        super().start(bus)
        bus.on("initialpose", lambda m: self.initial_pose())
        bus.each_tick(lambda now, dt: self.step(dt, moving=self.body.v != 0.0 or self.body.w != 0.0))
        bus.every(1.0 / self.rate_hz, self._publish, wanted="particlecloud")

    def _draw(self) -> None:
        g = self.rng.gauss
        self.offsets = [(g(0, 1), g(0, 1), g(0, 1)) for _ in range(self.count)]

    def initial_pose(self) -> None:
        """An operator set the pose: AMCL starts again from its initial covariance."""
        self.spread_xy, self.spread_yaw = INITIAL_SPREAD
        self._draw()

    def step(self, dt: float, moving: bool) -> None:
        k = math.exp(-dt / (TIGHTEN_S if moving else TIGHTEN_IDLE_S))
        self.spread_xy = MIN_SPREAD[0] + (self.spread_xy - MIN_SPREAD[0]) * k
        self.spread_yaw = MIN_SPREAD[1] + (self.spread_yaw - MIN_SPREAD[1]) * k

    def _publish(self) -> None:
        b, s, a = self.body, self.spread_xy, self.spread_yaw
        poses = [pose(b.x + s * dx, b.y + s * dy, b.yaw + a * da) for dx, dy, da in self.offsets]
        self.bus.publish("particlecloud", self.bus.dialect.particles(messages.header(ri.MAP_FRAME), poses))
