"""Where the robot link runs: turn the robot's sensor and planner topics into map overlays.

Each overlay topic gets a handler instead of the generic store-and-forward path: the laser,
particles, footprint and local plan are thinned to their UI rate (latest wins), placed on the
map and announced once per update under an overlay key; costmaps are rendered to tiles off
the event loop (robot.overlays.costmap) and announced as metadata. A background listener keeps
the robot's pose and transforms for placing them.
"""

from __future__ import annotations

import asyncio
import logging
from collections.abc import Callable, Coroutine
from typing import Any

from django.urls import reverse

from robot import interface as ri
from robot.link import connection as link_module
from robot.link.connection import RobotLink
from robot.link.subscriptions import register_handler
from robot.live.announce import apublish_state
from robot.live.fanout import Coalescer
from robot.live.groups import (
    OVERLAY_FOOTPRINT_KEY,
    OVERLAY_GLOBAL_COSTMAP_KEY,
    OVERLAY_LOCAL_COSTMAP_KEY,
    OVERLAY_LOCAL_PLAN_KEY,
    OVERLAY_PARTICLES_KEY,
    OVERLAY_SCAN_KEY,
    OVERLAY_SONAR_KEY,
)
from robot.overlays import shapes
from robot.overlays.costmap import Costmap, MapError, UpdateError, costmap_dir
from robot.overlays.frames import FrameTree, Pose2D

log = logging.getLogger(__name__)

Shape = Callable[[dict[str, Any], Pose2D], dict[str, Any]]
# topic key -> (overlay key, how its message becomes the overlay)
SHAPES: dict[str, tuple[str, Shape]] = {
    "scan": (OVERLAY_SCAN_KEY, shapes.scan_points),
    "sonar": (OVERLAY_SONAR_KEY, shapes.cloud_points),
    "particlecloud": (OVERLAY_PARTICLES_KEY, shapes.particle_poses),
    "footprint": (OVERLAY_FOOTPRINT_KEY, shapes.polygon_points),
    "local_plan": (OVERLAY_LOCAL_PLAN_KEY, shapes.path_points),
}
COSTMAPS: dict[str, tuple[str, str, str]] = {  # layer -> (costmap topic key, updates topic key, overlay key)
    "global": ("global_costmap", "global_costmap_updates", OVERLAY_GLOBAL_COSTMAP_KEY),
    "local": ("local_costmap", "local_costmap_updates", OVERLAY_LOCAL_COSTMAP_KEY),
}


class Overlays:
    def __init__(self) -> None:
        self.frames = FrameTree(map_frame=ri.MAP_FRAME)
        self.costmaps: dict[str, Costmap] = {}
        self._coalescers: dict[asyncio.AbstractEventLoop, Coalescer] = {}
        self._locks: dict[tuple[asyncio.AbstractEventLoop, str], asyncio.Lock] = {}

    # --- frames ------------------------------------------------------------------------

    def listen(self, name: str, msg_type: str, msg: dict[str, Any], t: float) -> None:
        """A link listener: keep the robot's pose and transforms."""
        try:
            if name == ri.topic("robot_pose").name:
                self.frames.set_robot_pose(msg)
            elif name in (ri.topic("tf").name, ri.topic("tf_static").name):
                self.frames.add_transforms(msg)
        except (AttributeError, TypeError, ValueError):
            log.debug("ignored a malformed %s message", name)

    # --- shapes ------------------------------------------------------------------------

    def on_shape(self, topic: ri.Topic, msg: dict[str, Any], t: float) -> None:
        loop = asyncio.get_running_loop()
        coalescer = self._coalescers.get(loop)
        if coalescer is None:
            coalescer = self._coalescers[loop] = Coalescer(self._send_shape, loop=loop)
        coalescer.offer(topic.key, topic.ui_rate_hz, (topic.key, msg, t))

    def shape(self, topic_key: str, msg: dict[str, Any], t: float) -> dict[str, Any]:
        """The overlay message for one robot message (placed on the map when its frame is known)."""
        _, make = SHAPES[topic_key]
        frame = shapes.header_frame(msg) or self.frames.map_frame
        stamp = shapes.stamp_seconds(msg.get("header"))
        base = {"frame": frame, "stamp": stamp, "received": t}
        where = self.frames.in_map(frame)
        if where is None:
            return {**base, "problem": f"waiting for where the {frame} frame is on the map"}
        try:
            return {**base, **make(msg, where)}
        except (AttributeError, KeyError, TypeError, ValueError) as exc:
            return {**base, "problem": f"malformed {topic_key} message: {exc}"}

    async def _send_shape(self, item: tuple[str, dict[str, Any], float]) -> None:
        topic_key, msg, t = item
        await apublish_state(SHAPES[topic_key][0], self.shape(topic_key, msg, t), t)

    # --- costmaps ----------------------------------------------------------------------

    def _lock(self, layer: str) -> asyncio.Lock:
        return self._locks.setdefault((asyncio.get_running_loop(), layer), asyncio.Lock())

    def on_costmap(self, layer: str) -> Callable[[ri.Topic, dict[str, Any], float], Coroutine[Any, Any, None]]:
        async def handle(topic: ri.Topic, msg: dict[str, Any], t: float) -> None:
            frame = shapes.header_frame(msg) or self.frames.map_frame
            async with self._lock(layer):
                costmap = self.costmaps.get(layer)
                if costmap is None or costmap.directory != costmap_dir():
                    costmap = self.costmaps[layer] = Costmap(layer, costmap_dir())
                try:
                    await asyncio.get_running_loop().run_in_executor(None, costmap.load, msg, frame)
                except (MapError, KeyError, TypeError, ValueError) as exc:
                    log.warning("ignored a malformed %s costmap: %s", layer, exc)
                    return
                await self._announce(layer, costmap, t)

        return handle

    def on_costmap_update(self, layer: str) -> Callable[[ri.Topic, dict[str, Any], float], Coroutine[Any, Any, None]]:
        async def handle(topic: ri.Topic, msg: dict[str, Any], t: float) -> None:
            async with self._lock(layer):
                costmap = self.costmaps.get(layer)
                if costmap is None or not costmap.version:
                    return  # the whole costmap comes first (the robot sends it to every new subscriber)
                try:
                    await asyncio.get_running_loop().run_in_executor(None, costmap.patch, msg)
                except UpdateError as exc:
                    log.warning("ignored a %s costmap update: %s", layer, exc)
                    return
                await self._announce(layer, costmap, t)

        return handle

    async def _announce(self, layer: str, costmap: Costmap, t: float) -> None:
        where = self.frames.in_map(costmap.frame)
        origin = None
        if where is not None and costmap.geometry is not None:
            g = costmap.geometry
            o = where.compose(Pose2D(g.origin_x, g.origin_y, g.origin_yaw))
            origin = {"x": round(o.x, 4), "y": round(o.y, 4), "yaw": round(o.yaw, 6)}
        url = reverse("dashboard:costmap-tile", kwargs={"layer": layer, "version": costmap.version, "name": "0-0-0"})
        meta = costmap.meta(origin, url.removesuffix("0-0-0.png"), t)
        await apublish_state(COSTMAPS[layer][2], meta, t)


overlays = Overlays()


def install() -> None:
    """Route the overlay topics to their handlers (wherever the link may run)."""
    for topic_key in SHAPES:
        register_handler(topic_key, overlays.on_shape)
    for layer, (costmap_key, updates_key, _) in COSTMAPS.items():
        register_handler(costmap_key, overlays.on_costmap(layer), arrays=True)
        register_handler(updates_key, overlays.on_costmap_update(layer), arrays=True)
    link_module.register_start(_listen_from_the_start)


def _listen_from_the_start(link: RobotLink) -> None:
    """Keep the robot's pose and transforms from the link's first message on: /tf_static is
    latched, sent once per subscription, and may come before any page asks for an overlay."""
    if overlays.listen not in link.listeners:
        link.listeners.append(overlays.listen)
