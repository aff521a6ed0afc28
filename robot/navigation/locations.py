"""Named locations: save the robot's current pose under a name, and send the robot to one."""

from __future__ import annotations

from typing import Any

from django.conf import settings

from robot.commands.pipeline import Command, InvalidCommand
from robot.link.bus import RobotError
from robot.live.announce import aget_state
from robot.models import Location
from robot.navigation.goals import asend_pose_goal, astart_goal, navigation_goal_message, new_goal_id
from robot.navigation.selectors import pose_of
from robot.navigation.status import goal_view


class LocationNotFound(RobotError):
    status_code = 404
    code = "not_found"


async def acurrent_pose() -> dict[str, float]:
    pose = pose_of((await aget_state("robot_pose")).get("robot_pose"))
    if pose is None:
        raise InvalidCommand("The robot's pose is not known yet (no /robot_pose received)", field="use_current_pose")
    return pose


def _location(name: str) -> Location:
    location = Location.objects.filter(name=name).first()
    if location is None:
        raise LocationNotFound(f"No location named {name!r}")
    return location


def location_go(*, user: Any, name: str) -> Command:
    """Send the robot to a named location: a move_base goal at its pose, or by name to the
    robot's own navigation action when ``NAVIGATION_BACKEND`` is ``cyborg_navigation``.
    ``result`` is the goal with its status."""

    async def send(location: Location) -> str:
        if settings.NAVIGATION_BACKEND == "cyborg_navigation":
            goal_id = new_goal_id()
            sent = await astart_goal(
                action="navigation", msg=navigation_goal_message(goal_id, location.name), goal_id=goal_id,
                user=user, x=location.x, y=location.y, yaw=location.yaw, location=location.name)
            outcome = f"goal {goal_id}: {location.name} by name via the robot's navigation"
        else:
            sent = await asend_pose_goal(user=user, x=location.x, y=location.y, yaw=location.yaw,
                                         location=location.name)
            outcome = f"goal {sent['id']} sent to {location.name} ({location.x:.2f}, {location.y:.2f})"
        command.result.update(goal_view(sent, None) or {})
        return outcome

    command = Command("navigation.go_to", {"location": name}, send, check=lambda: _location(name))
    return command
