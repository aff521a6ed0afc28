"""Where the robot link runs: render each new map, and remember what the robot says about goals.

Imported by ``RobotConfig.ready()`` so the handler and the tracker exist in every process
that may host the link (Daphne in the embedded default, ``manage.py robotlink``, tests).
"""

from __future__ import annotations

import asyncio
import itertools
import logging
import time
from collections.abc import Coroutine
from typing import Any

from robot import interface as ri
from robot.link.connection import RobotLink
from robot.link.hosting import register_background
from robot.link.subscriptions import register_handler
from robot.live.announce import aget_state, apublish_state
from robot.live.groups import GOAL_STATUS_KEY, MAP_META_KEY
from robot.navigation.mapimage import MapError, RenderedMap, map_dir, render_map
from robot.navigation.status import merge_statuses

log = logging.getLogger(__name__)

_sequence = itertools.count()
_newest_published = -1


def map_meta(rendered: RenderedMap, msg: dict[str, Any], t: float) -> dict[str, Any]:
    from django.urls import reverse

    g = rendered.geometry
    return {
        "version": rendered.version,
        "width": g.width, "height": g.height, "resolution": g.resolution,
        "origin": {"x": g.origin_x, "y": g.origin_y, "yaw": g.origin_yaw},
        "frame": (msg.get("header") or {}).get("frame_id") or ri.MAP_FRAME,
        "image_url": reverse("dashboard:map-image", kwargs={"version": rendered.version}),
        "received": t,
        "convert_ms": round(rendered.convert_ms, 1),
        "render_ms": round(rendered.render_ms, 1),
    }


def on_map(topic: ri.Topic, msg: dict[str, Any], t: float) -> Coroutine[Any, Any, None]:
    # A 4000x4000 grid is 16 M values: convert and render off the event loop.
    return _render_and_publish(msg, t, next(_sequence))


async def _render_and_publish(msg: dict[str, Any], t: float, seq: int) -> None:
    global _newest_published
    loop = asyncio.get_running_loop()
    try:
        rendered = await loop.run_in_executor(None, render_map, msg, map_dir())
    except (MapError, KeyError, TypeError, ValueError) as exc:
        log.warning("ignored a malformed map: %s", exc)
        return
    if seq < _newest_published:
        return  # a newer map finished rendering first
    _newest_published = seq
    log.info("map %s: %dx%d, converted in %.0f ms, %s in %.0f ms", rendered.version, rendered.geometry.width,
             rendered.geometry.height, rendered.convert_ms, "cached" if rendered.cached else "rendered",
             rendered.render_ms)
    await apublish_state(MAP_META_KEY, map_meta(rendered, msg, t), t)



# --- goal statuses ---------------------------------------------------------------------------


async def track_goal_statuses(link: RobotLink) -> None:
    """Keep the statuses the robot reports for goals, past actionlib's few-second window."""
    # The link's registry holds both status topics, by the names of the ROS it finds the robot runs.
    names = {ri.topic(f"{key}_status", ros).name: key for key in ("move_base", "navigation") for ros in ri.ROS_VERSIONS}
    pending: list[dict[str, Any]] = []
    wake = asyncio.Event()

    def listener(name: str, msg_type: str, msg: dict[str, Any], t: float) -> None:
        if name in names:
            pending.append({**msg, "action": names[name]})
            wake.set()

    link.listeners.append(listener)
    # This loop is the key's only writer, so it keeps its own copy and writes on change.
    known = (await aget_state(GOAL_STATUS_KEY)).get(GOAL_STATUS_KEY, {"goals": {}})
    try:
        while True:
            await wake.wait()
            wake.clear()
            batch, pending[:] = list(pending), []
            merged = merge_statuses(known, batch, now=time.time())
            if merged != known:
                known = merged
                await apublish_state(GOAL_STATUS_KEY, merged)
    finally:
        link.listeners.remove(listener)


def install() -> None:
    register_handler("map", on_map, arrays=True)
    register_background("navigation-goal-statuses", track_goal_statuses)
