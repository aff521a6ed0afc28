"""Map metres <-> grid cells <-> image pixels, and yaw <-> quaternion. Pure functions.

An OccupancyGrid is row-major from ``info.origin`` (the map position of cell (0, 0)'s
outer corner), rows going up the map's y axis. The rendered image has row 0 at the top,
so image y runs down: ``py = height - cell_y``. Pixel coordinates here are continuous:
(0, 0) is the top-left corner of the top-left pixel, (width, height) the bottom-right one.
``static/js/map/view.js`` implements the same transform for the browser.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class MapGeometry:
    width: int  # cells
    height: int
    resolution: float  # m/cell
    origin_x: float  # m
    origin_y: float
    origin_yaw: float = 0.0  # rad; map_server maps have 0, but the message allows any

    @classmethod
    def from_info(cls, info: dict[str, Any]) -> MapGeometry:
        origin = info["origin"]
        return cls(
            width=int(info["width"]), height=int(info["height"]), resolution=float(info["resolution"]),
            origin_x=float(origin["position"]["x"]), origin_y=float(origin["position"]["y"]),
            origin_yaw=quaternion_to_yaw(origin["orientation"]),
        )

    @classmethod
    def from_meta(cls, meta: dict[str, Any]) -> MapGeometry:
        o = meta["origin"]
        return cls(int(meta["width"]), int(meta["height"]), float(meta["resolution"]),
                   float(o["x"]), float(o["y"]), float(o.get("yaw", 0.0)))


def map_to_cell_coords(g: MapGeometry, x: float, y: float) -> tuple[float, float]:
    """Continuous (column, row) of a map point; row 0 is the grid's first (bottom) row."""
    dx, dy = x - g.origin_x, y - g.origin_y
    c, s = math.cos(g.origin_yaw), math.sin(g.origin_yaw)
    return (c * dx + s * dy) / g.resolution, (-s * dx + c * dy) / g.resolution


def cell_coords_to_map(g: MapGeometry, col: float, row: float) -> tuple[float, float]:
    u, v = col * g.resolution, row * g.resolution
    c, s = math.cos(g.origin_yaw), math.sin(g.origin_yaw)
    return g.origin_x + c * u - s * v, g.origin_y + s * u + c * v


def map_to_pixel(g: MapGeometry, x: float, y: float) -> tuple[float, float]:
    col, row = map_to_cell_coords(g, x, y)
    return col, g.height - row


def pixel_to_map(g: MapGeometry, px: float, py: float) -> tuple[float, float]:
    return cell_coords_to_map(g, px, g.height - py)


def map_to_cell(g: MapGeometry, x: float, y: float) -> tuple[int, int] | None:
    """(row, column) index of the cell holding a map point, or None off the map."""
    col, row = map_to_cell_coords(g, x, y)
    if not (math.isfinite(col) and math.isfinite(row)):
        return None
    c, r = math.floor(col), math.floor(row)
    if 0 <= c < g.width and 0 <= r < g.height:
        return r, c
    return None


def map_bounds(g: MapGeometry) -> tuple[float, float, float, float]:
    """(min x, min y, max x, max y) of the map's corners, in metres."""
    corners = [cell_coords_to_map(g, c, r) for c in (0, g.width) for r in (0, g.height)]
    xs, ys = [p[0] for p in corners], [p[1] for p in corners]
    return min(xs), min(ys), max(xs), max(ys)


def yaw_to_quaternion(yaw: float) -> dict[str, float]:
    return {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2.0), "w": math.cos(yaw / 2.0)}


def quaternion_to_yaw(q: dict[str, Any]) -> float:
    x, y, z, w = (float(q.get(k) or 0.0) for k in ("x", "y", "z", "w"))
    if x == y == z == w == 0.0:
        return 0.0  # an all-zero quaternion (message defaults) means "no rotation"
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def normalize_angle(a: float) -> float:
    return math.atan2(math.sin(a), math.cos(a))
