"""move_base's costmaps as costmap_2d makes them (obstacles from the world, inflated, with their
updates), its footprint and its local plan.

Costs follow costmap_2d's inflation layer (lethal at an obstacle, inscribed within the robot's
inscribed radius, then ``252 * exp(-scaling * (d - inscribed))`` out to the inflation radius)
and reach the wire through costmap_2d's translation to OccupancyGrid values (100 lethal,
99 inscribed, 1..98 inflated, 0 free, -1 unknown). Distances come from scipy's Euclidean
distance transform. The global costmap covers the world at a resolution that keeps it under
``MAX_GLOBAL_CELLS``; the local one is a rolling window around the robot in the odometry frame.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.ndimage import distance_transform_edt

from robot import interface as ri

from .. import messages
from ..bus import Bus, SimNode
from ..world import OCCUPIED, UNKNOWN, Base, WorldMap, grid, pose

INSCRIBED_RADIUS = 0.25  # m: half the Pioneer LX's width
INFLATION_RADIUS = 0.55  # m
COST_SCALING = 10.0
MAX_GLOBAL_CELLS = 250_000
LOCAL_SIZE_M = 4.0
ODOM_FRAME = "odom"
# The Pioneer LX's outline on base_link (~0.7 x 0.5 m), as move_base's footprint parameter.
FOOTPRINT = ((0.35, 0.25), (0.35, -0.25), (-0.35, -0.25), (-0.35, 0.25))


def to_grid_values(distance: np.ndarray, unknown: np.ndarray) -> np.ndarray:
    """OccupancyGrid values (int8) for cells at ``distance`` metres from the nearest obstacle."""
    with np.errstate(over="ignore"):
        cost = 252.0 * np.exp(-COST_SCALING * (distance - INSCRIBED_RADIUS))
    values = np.where(distance <= INFLATION_RADIUS, 1 + (97 * (np.floor(cost) - 1)) // 251, 0)
    values = np.where(distance <= INSCRIBED_RADIUS, 99, values)
    values = np.where(distance == 0, 100, values)
    values = np.where(unknown & (distance > 0), -1, values)
    return values.astype(np.int8)


@dataclass(frozen=True)
class Grid:
    data: np.ndarray  # int8, row 0 at the origin
    resolution: float
    origin_x: float
    origin_y: float


def global_costmap(world: WorldMap) -> Grid:
    f = max(1, math.ceil(math.sqrt(world.width * world.height / MAX_GLOBAL_CELLS)))
    blocks = world.blocks(f, UNKNOWN)  # a block is an obstacle if any cell is, unknown if all are
    obstacle, unknown = (blocks >= OCCUPIED).any(axis=(1, 3)), (blocks == UNKNOWN).all(axis=(1, 3))
    res = world.resolution * f
    distance = distance_transform_edt(~obstacle) * res
    return Grid(to_grid_values(distance, unknown), res, world.origin_x, world.origin_y)


def local_costmap(world: WorldMap, map_from_odom: tuple[float, float, float], odom_xy: tuple[float, float],
                  size_m: float = LOCAL_SIZE_M) -> Grid:
    """The window of ``size_m`` around the robot (at ``odom_xy`` in the odometry frame), in that frame."""
    res = world.resolution
    n = round(size_m / res)
    ox = math.floor((odom_xy[0] - size_m / 2) / res) * res  # costmap_2d keeps the origin on the cell grid
    oy = math.floor((odom_xy[1] - size_m / 2) / res) * res
    tx, ty, tyaw = map_from_odom
    c, s = math.cos(tyaw), math.sin(tyaw)
    centres = (np.arange(n) + 0.5) * res
    u, v = np.meshgrid(ox + centres, oy + centres)  # rows along y, like the grid
    mx, my = tx + c * u - s * v, ty + s * u + c * v
    # The world around the window, with room for inflation from obstacles just outside it.
    margin = INFLATION_RADIUS + res
    c0 = max(0, math.floor((mx.min() - margin - world.origin_x) / res))
    c1 = min(world.width, math.ceil((mx.max() + margin - world.origin_x) / res) + 1)
    r0 = max(0, math.floor((my.min() - margin - world.origin_y) / res))
    r1 = min(world.height, math.ceil((my.max() + margin - world.origin_y) / res) + 1)
    values = np.zeros((n, n), dtype=np.int8)
    if c1 > c0 and r1 > r0:
        crop = world.grid[r0:r1, c0:c1]
        crop_values = to_grid_values(distance_transform_edt(crop < OCCUPIED) * res, crop == UNKNOWN)
        cols = np.floor((mx - world.origin_x) / res).astype(np.int64) - c0
        rows = np.floor((my - world.origin_y) / res).astype(np.int64) - r0
        inside = (rows >= 0) & (rows < r1 - r0) & (cols >= 0) & (cols < c1 - c0)
        values[inside] = crop_values[rows[inside], cols[inside]]
    return Grid(values, res, ox, oy)


def footprint(x: float, y: float, yaw: float) -> list[tuple[float, float]]:
    """The robot's outline on the map for a base at (x, y, yaw)."""
    c, s = math.cos(yaw), math.sin(yaw)
    return [(x + c * px - s * py, y + s * px + c * py) for px, py in FOOTPRINT]


def local_plan(x: float, y: float, yaw: float, v: float, w: float, horizon_s: float = 1.5,
               steps: int = 15) -> list[tuple[float, float, float]]:
    """The trajectory the local planner picked: the current velocities rolled out ``horizon_s``
    ahead from (x, y, yaw), as TrajectoryPlannerROS publishes it."""
    poses = [(x, y, yaw)]
    dt = horizon_s / steps
    for _ in range(steps):
        x += v * math.cos(yaw + w * dt / 2) * dt
        y += v * math.sin(yaw + w * dt / 2) * dt
        yaw += w * dt
        poses.append((x, y, yaw))
    return poses


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
        name = self.bus.topic("global_costmap").name
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
