"""Frames the live websocket sends; one shape for the first snapshot and for updates."""

from __future__ import annotations

from typing import Any

from robot import interface as ri
from robot.commands.modes import MODE_REQUEST_KEY
from robot.live.state import status_view
from robot.navigation.shared import SERVER_KEYS as NAVIGATION_KEYS
from robot.teleop.latch import LATCH_KEY

# Whole occupancy grids are far too big for a browser socket; the map page gets an image.
_BULKY_TYPES = {"nav_msgs/OccupancyGrid"}
# Keys the server itself writes to the latest-state store (not ROS topics), same frames.
SERVER_KEYS = frozenset({MODE_REQUEST_KEY, LATCH_KEY, *NAVIGATION_KEYS})


def watchable_keys() -> set[str]:
    return {t.key for t in ri.topics() if t.type not in _BULKY_TYPES} | SERVER_KEYS


def live_frame(update: dict[str, Any]) -> dict[str, Any]:
    return {"kind": "update", "key": update["key"], "msg": update["msg"], "t": update["t"]}


def status_frame(status: dict[str, Any] | None) -> dict[str, Any]:
    view = status_view(status)
    return {"kind": "status", **{k: v for k, v in view.items() if k != "type"}}
