"""move_base's costmaps (with their updates), footprint and local plan (simulator/costmaps.py)."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from robot import interface as ri

from .. import messages
from ..bus import Bus, SimNode
from ..costmaps import ODOM_FRAME, Grid, footprint, global_costmap, local_costmap, local_plan
from ..world import Base, WorldMap
from .shapes import grid, pose


def grid_message(g: Grid, frame: str) -> dict[str, Any]:
    h, w = g.data.shape
    return grid(g.data.ravel().tolist(), w, h, g.resolution, g.origin_x, g.origin_y, messages.stamp(), frame)


def update_message(g: Grid, frame: str, x: int, y: int, width: int, height: int) -> dict[str, Any]:
    cells = g.data[y:y + height, x:x + width]
    return {"header": messages.header(frame), "x": x, "y": y, "width": width, "height": height,
            "data": cells.ravel().tolist()}


class CostmapNode(SimNode):
    """move_base's costmaps, footprint and local plan.

    The global costmap goes out whole (latched, so each new subscriber gets it, as costmap_2d
    does) and then as updates of the window the robot's sensors reach; the local costmap goes
    out whole when its rolling window moved, else as an update of the window.
    """

    names: tuple[str, ...] = ()  # move_base's (the navigation node names /move_base)
    publishes = ("global_costmap", "global_costmap_updates", "local_costmap", "local_costmap_updates",
                 "footprint", "local_plan")
    GLOBAL_UPDATE_M = 4.0  # side of the global costmap window updated around the robot

    def __init__(self, body: Base, world_map: WorldMap, navigating: Callable[[], bool]) -> None:
        self.body = body
        self.world = world_map
        self.navigating = navigating
        self._global: Grid | None = None
        self._local_origin: tuple[float, float] | None = None
        self._planned = False

    def start(self, bus: Bus) -> None:
        super().start(bus)
        bus.every(1.0, self._pub_global)
        bus.every(0.5, self._pub_local)
        bus.every(0.2, self._pub_footprint, wanted="footprint")
        bus.every(0.2, self._pub_local_plan)

    def _pub_global(self) -> None:
        name = ri.topic("global_costmap").name
        if self.bus.wants("global_costmap") and self._global is None:
            self._global = global_costmap(self.world)  # built for its first listener, then kept
            self.bus.publish_name(name, grid_message(self._global, ri.MAP_FRAME), latch=True)
            return
        if self._global is None or not self.bus.wants("global_costmap_updates"):
            return
        g, b = self._global, self.body
        h, w = g.data.shape
        half = self.GLOBAL_UPDATE_M / 2
        x0 = max(0, math.floor((b.x - half - g.origin_x) / g.resolution))
        y0 = max(0, math.floor((b.y - half - g.origin_y) / g.resolution))
        x1 = min(w, math.ceil((b.x + half - g.origin_x) / g.resolution))
        y1 = min(h, math.ceil((b.y + half - g.origin_y) / g.resolution))
        if x1 > x0 and y1 > y0:
            self.bus.publish("global_costmap_updates", update_message(g, ri.MAP_FRAME, x0, y0, x1 - x0, y1 - y0))

    def _pub_local(self) -> None:
        wants_full, wants_update = self.bus.wants("local_costmap"), self.bus.wants("local_costmap_updates")
        if not (wants_full or wants_update):
            return
        b = self.body
        g = local_costmap(self.world, b.map_from_odom(), (b.odom_x, b.odom_y))
        origin = (g.origin_x, g.origin_y)
        if origin != self._local_origin or not wants_update:
            self._local_origin = origin
            if wants_full:
                self.bus.publish("local_costmap", grid_message(g, ODOM_FRAME))
        else:
            h, w = g.data.shape
            self.bus.publish("local_costmap_updates", update_message(g, ODOM_FRAME, 0, 0, w, h))

    def _pub_footprint(self) -> None:
        b = self.body
        points = [{"x": x, "y": y, "z": 0.0} for x, y in footprint(b.x, b.y, b.yaw)]
        self.bus.publish("footprint", {"header": messages.header(ri.MAP_FRAME), "polygon": {"points": points}})

    def _pub_local_plan(self) -> None:
        active, was_active = self.navigating(), self._planned
        self._planned = active
        if not self.bus.wants("local_plan") or not (active or was_active):
            return
        b = self.body
        poses = local_plan(b.odom_x, b.odom_y, b.odom_yaw, b.v, b.w) if active else []
        self.bus.publish("local_plan", {"header": messages.header(ODOM_FRAME), "poses": [
            {"header": messages.header(ODOM_FRAME), "pose": pose(x, y, yaw)} for x, y, yaw in poses]})
