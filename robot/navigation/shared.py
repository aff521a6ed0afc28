"""Latest-state keys of the navigation package and how they reach the pages.

These keys are written by the server (not the robot): the map's metadata (the grid itself
never goes into the store), the goal this server sent last, and the statuses the robot
reported for recent goals. Pages watch them on the live socket like topic keys.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from channels.layers import get_channel_layer
from django.conf import settings

from robot.live.groups import TopicUpdate, topic_group
from robot.live.state import get_store

MAP_META_KEY = "map_meta"
GOAL_KEY = "nav_goal"
GOAL_STATUS_KEY = "nav_goal_status"
LOCATIONS_KEY = "nav_locations"  # sent on change only (robot.navigation.broadcast)
SERVER_KEYS = (MAP_META_KEY, GOAL_KEY, GOAL_STATUS_KEY, LOCATIONS_KEY)


def map_dir() -> Path:
    return Path(settings.VAR_DIR) / "maps"


def server_update(key: str, msg: dict[str, Any], t: float | None = None) -> TopicUpdate:
    """A live update of a key the server writes itself (no ROS topic behind it)."""
    return {"type": "robot.update", "key": key, "topic": "", "msg_type": "", "msg": msg, "t": t or time.time()}


async def apublish_state(key: str, msg: dict[str, Any], t: float | None = None) -> None:
    """Store ``msg`` as the latest value of ``key`` and send it to every page watching it."""
    update = server_update(key, msg, t)
    await get_store().aput(key, dict(update))
    await get_channel_layer().group_send(topic_group(key), update)


async def aget_state(*keys: str) -> dict[str, dict[str, Any]]:
    """The latest message of each key that has one."""
    entries = await get_store().aget_many(list(keys))
    return {k: e["msg"] for k, e in entries.items()}
