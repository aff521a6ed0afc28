"""Message shapes several nodes build: a pose in the map, a tf transform, an occupancy grid."""

from __future__ import annotations

from typing import Any

from robot import interface as ri

from .. import messages, world


def pose(x: float, y: float, yaw: float) -> dict[str, Any]:
    return {"position": {"x": x, "y": y, "z": 0.0}, "orientation": world.yaw_to_quaternion(yaw)}


def body_pose(b: world.Base) -> dict[str, Any]:
    return pose(b.x, b.y, b.yaw)


def transform(parent: str, child: str, x: float, y: float, yaw: float) -> dict[str, Any]:
    return {"header": messages.header(parent), "child_frame_id": child,
            "transform": {"translation": {"x": x, "y": y, "z": 0.0}, "rotation": world.yaw_to_quaternion(yaw)}}


def grid(data: list[int], width: int, height: int, res: float, ox: float, oy: float,
         load_time: dict[str, int], frame: str = ri.MAP_FRAME) -> dict[str, Any]:
    return {"header": messages.header(frame), "info": {
        "map_load_time": load_time, "resolution": res, "width": width, "height": height,
        "origin": pose(ox, oy, 0.0)}, "data": data}
