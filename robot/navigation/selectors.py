"""Read-only views of the map and navigation state, for the API, the page and services."""

from __future__ import annotations

from typing import Any

from asgiref.sync import async_to_sync
from django.conf import settings

from robot.live.announce import aget_state
from robot.live.groups import GOAL_KEY, GOAL_STATUS_KEY, MAP_META_KEY
from robot.models import Location
from robot.navigation.status import goal_view
from robot.navigation.transforms import quaternion_to_yaw


def pose_of(msg: dict[str, Any] | None) -> dict[str, float] | None:
    """{x, y, yaw} of a geometry_msgs/Pose (None without one)."""
    if not msg or "position" not in msg:
        return None
    p = msg["position"]
    return {"x": float(p["x"]), "y": float(p["y"]), "yaw": quaternion_to_yaw(msg.get("orientation") or {})}


async def anavigation_status() -> dict[str, Any]:
    state = await aget_state(GOAL_KEY, GOAL_STATUS_KEY, MAP_META_KEY, "robot_pose", "current_location")
    location = state.get("current_location")
    return {
        "goal": goal_view(state.get(GOAL_KEY), state.get(GOAL_STATUS_KEY)),
        "robot_pose": pose_of(state.get("robot_pose")),
        "current_location": location.get("data") if location else None,
        "map_version": (state.get(MAP_META_KEY) or {}).get("version"),
        "backend": settings.NAVIGATION_BACKEND,
    }


navigation_status = async_to_sync(anavigation_status)


async def amap_meta() -> dict[str, Any] | None:
    return (await aget_state(MAP_META_KEY)).get(MAP_META_KEY)


map_meta = async_to_sync(amap_meta)


def location_list() -> list[dict[str, Any]]:
    fields = ("name", "map_name", "x", "y", "yaw", "threshold", "description")
    return list(Location.objects.values(*fields))
