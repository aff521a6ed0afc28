"""move_base's costmaps as costmap_2d makes them: obstacles from the world, inflated.

Costs follow costmap_2d's inflation layer (lethal at an obstacle, inscribed within the robot's
inscribed radius, then ``252 * exp(-scaling * (d - inscribed))`` out to the inflation radius)
and reach the wire through costmap_2d's translation to OccupancyGrid values (100 lethal,
99 inscribed, 1..98 inflated, 0 free, -1 unknown). Distances come from scipy's Euclidean
distance transform. The global costmap covers the world at a resolution that keeps it under
``MAX_GLOBAL_CELLS``; the local one is a rolling window around the robot in the odometry frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.ndimage import distance_transform_edt

from .world import OCCUPIED, UNKNOWN, WorldMap

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
