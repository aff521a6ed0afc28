"""move_base's local planner, simplified: follow an A* path with a pure-pursuit controller."""

from __future__ import annotations

import math
from dataclasses import dataclass

from .world import Base, wrap

RUNNING, SUCCEEDED, ABORTED = "running", "succeeded", "aborted"


@dataclass
class Navigator:
    base: Base
    max_v: float = 0.6
    max_w: float = 1.2
    lookahead: float = 0.4
    xy_tolerance: float = 0.15
    yaw_tolerance: float = 0.12
    patience_s: float = 10.0  # no progress for this long: give up (move_base's controller patience)

    def __post_init__(self) -> None:
        self.path: list[tuple[float, float]] = []
        self.goal_yaw = 0.0
        self.idx = 0
        self.active = False
        self._best = math.inf
        self._best_t = 0.0

    def start(self, path: list[tuple[float, float]], goal_yaw: float, now: float) -> None:
        self.path, self.goal_yaw, self.idx, self.active = path, goal_yaw, 0, True
        self._best, self._best_t = math.inf, now

    def stop(self, now: float) -> None:
        if self.active:
            self.active = False
            self.base.command(0.0, 0.0, now)

    def remaining(self) -> list[tuple[float, float]]:
        if not self.active:
            return []
        return [(self.base.x, self.base.y), *self.path[self.idx + 1:]]

    def step(self, now: float) -> str:
        if not self.active:
            return RUNNING
        b = self.base
        gx, gy = self.path[-1]
        dist = math.hypot(gx - b.x, gy - b.y)
        if dist < self._best - 0.05:
            self._best, self._best_t = dist, now
        elif now - self._best_t > self.patience_s:
            self.stop(now)
            return ABORTED
        if dist < self.xy_tolerance:
            err = wrap(self.goal_yaw - b.yaw)
            if abs(err) < self.yaw_tolerance:
                self.stop(now)
                return SUCCEEDED
            self._best_t = now
            b.command(0.0, max(-self.max_w, min(self.max_w, 2.0 * err)), now)
            return RUNNING
        while self.idx < len(self.path) - 1 and math.hypot(self.path[self.idx][0] - b.x,
                                                           self.path[self.idx][1] - b.y) < self.lookahead:
            self.idx += 1
        tx, ty = self.path[self.idx]
        err = wrap(math.atan2(ty - b.y, tx - b.x) - b.yaw)
        if abs(err) > 0.8:
            b.command(0.0, math.copysign(self.max_w, err), now)
        else:
            v = min(self.max_v, 0.3 + dist) * max(0.0, math.cos(err))
            b.command(v, max(-self.max_w, min(self.max_w, 2.5 * err)), now)
        return RUNNING
