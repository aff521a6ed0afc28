"""Navigation commands: send a goal, cancel it, set the initial pose.

The goal this server sent last is "the current goal" (as on the robot: the latest goal
wins); it is kept in the latest-state store and broadcast, so everyone watching the map
sees the same goal, and its status comes from what the robot reports (``handlers.py``).
"""

from __future__ import annotations

import math
import time
import uuid
from typing import Any

from robot import interface as ri
from robot.commands.motors import ensure_motors_on
from robot.commands.pipeline import Command, arun
from robot.link.bus import apublish, arequest
from robot.live.announce import aget_state, apublish_state
from robot.live.groups import GOAL_KEY
from robot.navigation.selectors import anavigation_status
from robot.navigation.status import GOAL_ID_PREFIX, TERMINAL_STATES, goal_view
from robot.navigation.transforms import normalize_angle, yaw_to_quaternion
from robot.navigation.validation import POSE_FIELDS, acheck_position, audit_params, clean_yaw, number, only_fields

# PoseWithCovarianceStamped for /initialpose: 0.5 m std-dev in x and y, 15 degrees in yaw.
INITIAL_POSE_VAR_XY = 0.25
INITIAL_POSE_VAR_YAW = math.radians(15) ** 2  # ~0.0685
ZERO_STAMP = {"secs": 0, "nsecs": 0}  # actionlib stamps goals with the robot's clock on receipt


def new_goal_id() -> str:
    return f"{GOAL_ID_PREFIX}{uuid.uuid4().hex[:16]}"


def pose(x: float, y: float, yaw: float) -> dict[str, Any]:
    return {"position": {"x": x, "y": y, "z": 0.0}, "orientation": yaw_to_quaternion(yaw)}


def move_base_goal_message(goal_id: str, x: float, y: float, yaw: float) -> dict[str, Any]:
    target = {"header": {"frame_id": ri.MAP_FRAME}, "pose": pose(x, y, yaw)}
    return {"header": {"frame_id": ri.MAP_FRAME}, "goal_id": {"stamp": ZERO_STAMP, "id": goal_id},
            "goal": {"target_pose": target}}


def navigation_goal_message(goal_id: str, location_name: str) -> dict[str, Any]:
    return {"header": {}, "goal_id": {"stamp": ZERO_STAMP, "id": goal_id},
            "goal": {"order": ri.NAVIGATION_ORDERS[0], "location_name": location_name}}


def initial_pose_message(x: float, y: float, yaw: float) -> dict[str, Any]:
    covariance = [0.0] * 36
    covariance[0] = covariance[7] = INITIAL_POSE_VAR_XY
    covariance[35] = INITIAL_POSE_VAR_YAW
    return {"header": {"frame_id": ri.MAP_FRAME}, "pose": {"pose": pose(x, y, yaw), "covariance": covariance}}


def cancel_message(goal_id: str = "") -> dict[str, Any]:
    """An empty id with a zero stamp cancels every goal of that action server."""
    return {"stamp": ZERO_STAMP, "id": goal_id}


async def apublish_action(action_key: str, suffix: str, msg: dict[str, Any]) -> None:
    name, msg_type = ri.action_topic(action_key, suffix)
    await arequest("publish", topic=name, msg_type=msg_type, msg=msg)


async def cancel_every_goal(by: str) -> str:
    """The E-STOP's step: an empty goal id cancels every goal of the server, ours and any a
    robot-side node sent."""
    for key in ("move_base", "navigation"):
        await apublish_action(key, "cancel", cancel_message())
    return "all navigation goals cancelled"


async def astart_goal(*, action: str, msg: dict[str, Any], goal_id: str, user: Any, x: float, y: float, yaw: float,
                      location: str | None = None) -> dict[str, Any]:
    """Send an action goal and make it the current goal for every watcher (input already checked)."""
    await ensure_motors_on("a navigation goal")
    await apublish_action(action, "goal", msg)
    goal = {"id": goal_id, "action": action, "x": x, "y": y, "yaw": yaw, "location": location,
            "by": user.get_username() if user is not None else "", "sent": time.time(), "cancel_requested": False}
    await apublish_state(GOAL_KEY, goal)
    return goal


async def asend_pose_goal(*, user: Any, x: float, y: float, yaw: float, location: str | None = None) -> dict[str, Any]:
    await acheck_position(x, y)
    goal_id = new_goal_id()
    yaw = normalize_angle(yaw)
    return await astart_goal(action="move_base", msg=move_base_goal_message(goal_id, x, y, yaw), goal_id=goal_id,
                             user=user, x=x, y=y, yaw=yaw, location=location)


def _pose(data: dict[str, Any]) -> tuple[float, float, float]:
    only_fields(data, POSE_FIELDS)
    return number(data.get("x"), "x"), number(data.get("y"), "y"), clean_yaw(data.get("yaw"))


def goal_send(*, user: Any, data: dict[str, Any]) -> Command:
    """Validate {x, y, yaw} against the map and send it to move_base; ``result`` is the goal with its status."""

    async def send(pose: tuple[float, float, float]) -> str:
        x, y, yaw = pose
        sent = await asend_pose_goal(user=user, x=x, y=y, yaw=yaw)
        command.result.update(goal_view(sent, None) or {})
        return f"goal {sent['id']} sent to ({x:.2f}, {y:.2f}) facing {math.degrees(sent['yaw']):.0f}°"

    params = audit_params(**{k: data.get(k) for k in ("x", "y", "yaw")})
    command = Command("navigation.goal", params, send, check=lambda: _pose(data))
    return command


async def agoal_send(*, user: Any, source: str, data: dict[str, Any]) -> dict[str, Any]:
    command = goal_send(user=user, data=data)
    await arun(command, user=user, source=source)
    return command.result


def goal_cancel() -> Command:
    """Cancel the current goal; with none under way, cancel every move_base goal (stop navigating).
    ``result`` is the navigation status afterwards, and ``cancel_sent``: a goal was under way and this
    cancel went out for it (the robot may have ended it already by the time the status is read)."""

    async def send(_: None) -> str:
        goal = (await anavigation_status())["goal"]
        if goal and goal["status"] not in TERMINAL_STATES:
            await apublish_action(goal["action"], "cancel", cancel_message(goal["id"]))
            stored = (await aget_state(GOAL_KEY)).get(GOAL_KEY) or {}
            if stored.get("id") == goal["id"]:
                await apublish_state(GOAL_KEY, {**stored, "cancel_requested": True})
            outcome = f"cancel requested for goal {goal['id']}"
        else:
            await apublish_action("move_base", "cancel", cancel_message())
            outcome = "no goal of ours under way: cancelled every move_base goal"
        command.result.update(await anavigation_status(), cancel_sent=outcome.startswith("cancel requested"))
        return outcome

    command = Command("navigation.cancel", {}, send)
    return command


def initial_pose_set(*, data: dict[str, Any]) -> Command:
    """Publish /initialpose (the robot re-localises there); unexplored cells are allowed, obstacles not.
    ``result`` is the pose sent."""

    async def send(pose: tuple[float, float, float]) -> str:
        x, y, yaw = pose
        heading = normalize_angle(yaw)
        await acheck_position(x, y, allow_unknown=True)
        await apublish("initialpose", initial_pose_message(x, y, heading))
        command.result.update(x=x, y=y, yaw=heading)
        return f"initial pose set to ({x:.2f}, {y:.2f}) facing {math.degrees(heading):.0f}°"

    params = audit_params(**{k: data.get(k) for k in ("x", "y", "yaw")})
    command = Command("navigation.initial_pose", params, send, check=lambda: _pose(data))
    return command
