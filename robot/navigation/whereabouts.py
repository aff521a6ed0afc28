"""Which named location the robot is at, for the pages' "At location".

The robot's own navigation node answers for the places in its database; a place added here
(admin, API, map page) is unknown to it, so after arriving there it says "". Then the server
answers from its own named locations: the nearest whose arrival radius holds the robot's pose.
"""

from __future__ import annotations

import asyncio
import math
import time
from collections.abc import Iterable
from typing import Any

from asgiref.sync import sync_to_async

from robot import interface as ri
from robot.link.connection import RobotLink
from robot.link.hosting import register_background
from robot.live.announce import apublish_state
from robot.live.groups import AT_LOCATION_KEY
from robot.navigation.seeding import location_seed

# A named place as (name, x, y, arrival radius).
Place = tuple[str, float, float, float]
# What the robot said it was at, with its pose when it said so.
Report = tuple[str, dict[str, Any] | None]
RECHECK_S = 0.5  # at most this often; poses arrive at 10 Hz
PLACES_FRESH_S = 2.0  # a location added or moved shows within this
SEED_STILL_M = 0.25


def location_at(x: float, y: float, places: Iterable[Place]) -> str:
    """The nearest place whose radius holds (x, y); "" if none."""
    inside = [(math.hypot(x - px, y - py), name) for name, px, py, radius in places
              if math.hypot(x - px, y - py) <= radius]
    return min(inside)[1] if inside else ""


def whereabouts(robot_says: str, pose: dict[str, Any] | None, places: Iterable[Place]) -> dict[str, str]:
    if robot_says:
        return {"name": robot_says, "source": "robot"}
    if pose is None:
        return {"name": "", "source": ""}
    name = location_at(float(pose["position"]["x"]), float(pose["position"]["y"]), places)
    return {"name": name, "source": "server" if name else ""}


def settled_pose(previous: Report | None, report: Report) -> dict[str, Any] | None:
    """The pose to seed the place the robot names at: only once it has named it twice in a row without
    moving, since a report can be older than the pose beside it (the place it just left)."""
    name, pose = report
    if previous is None or not name or previous[0] != name or pose is None or previous[1] is None:
        return None
    moved = math.hypot(float(pose["position"]["x"]) - float(previous[1]["position"]["x"]),
                       float(pose["position"]["y"]) - float(previous[1]["position"]["y"]))
    return pose if moved <= SEED_STILL_M else None


def _places() -> list[Place]:
    from robot.models import Location

    return list(Location.objects.values_list("name", "x", "y", "threshold"))


async def track_whereabouts(link: RobotLink) -> None:
    pose_topic, location_topic = ri.topic("robot_pose").name, ri.topic("current_location").name
    latest: dict[str, Any] = {}
    wake = asyncio.Event()
    reported: Report | None = None
    to_seed: tuple[str, dict[str, Any]] | None = None

    def listener(name: str, msg_type: str, msg: dict[str, Any], t: float) -> None:
        nonlocal reported, to_seed
        if name in (pose_topic, location_topic):
            latest[name] = msg
            wake.set()
        if name == location_topic:
            report = (str(msg.get("data") or ""), latest.get(pose_topic))
            if (settled := settled_pose(reported, report)) is not None:
                to_seed = (report[0], settled)
            reported = report

    link.listeners.append(listener)
    shown: dict[str, str] | None = None
    places: list[Place] = []
    places_at = -math.inf
    tried: set[str] = set()  # names the robot reported that were seeded (or could not be)
    try:
        while True:
            await wake.wait()
            wake.clear()
            if time.monotonic() - places_at > PLACES_FRESH_S:
                places, places_at = await sync_to_async(_places)(), time.monotonic()
            robot_says = (latest.get(location_topic) or {}).get("data", "")
            pose = latest.get(pose_topic)
            if to_seed is not None and to_seed[0] not in tried | {p[0] for p in places}:
                tried.add(to_seed[0])  # once per name and run: an admin's delete stands until then
                if await sync_to_async(location_seed)(name=to_seed[0], pose=to_seed[1]):
                    places_at = -math.inf  # look again at once
            to_seed = None
            now = whereabouts(robot_says, pose, places)
            if now != shown:
                shown = now
                await apublish_state(AT_LOCATION_KEY, now)
            await asyncio.sleep(RECHECK_S)
    finally:
        link.listeners.remove(listener)


def install() -> None:
    register_background("navigation-whereabouts", track_whereabouts)
