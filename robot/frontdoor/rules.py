"""What a person may publish or call through the front door, as the product's own commands.

Nothing a tool sends goes to the robot as it came: velocity goes through the drive rules (the
session's ``Driver``); the robot's command topics (events, speech, emotion, sound, dome, mode, a
navigation goal on ``/move_base_simple/goal``, ``/initialpose``) and motor services become the
same ``Command`` the pages run, through the pipeline's role check, input check, E-STOP gate and
audit; an admin's allowlist (``FrontDoorAllowance``) adds further names, run as
``frontdoor.publish``/``frontdoor.call``. rosapi's read-only services answer anyone signed in.
Everything else is refused with a reason.
"""

from __future__ import annotations

from typing import Any

from robot import interface as ri
from robot.commands.modes import change_mode
from robot.commands.motors import set_motors
from robot.commands.pipeline import Command
from robot.commands.tool import STRING_COMMANDS, string_command
from robot.frontdoor.protocol import finite
from robot.link import bus
from robot.navigation.goals import goal_send, initial_pose_set
from robot.navigation.transforms import quaternion_to_yaw
from robot.teleop.twist import server_limits

# rosapi's services that only read (its parameter writes stay with the robot's own tools).
ROSAPI_READ_ONLY = frozenset({
    "topics", "topic_type", "topics_for_type", "topics_and_raw_types", "services", "service_type",
    "services_for_type", "service_node", "service_providers", "service_host", "nodes", "node_details",
    "publishers", "subscribers", "get_time", "message_details", "service_request_details",
    "service_response_details", "get_ros_version", "action_servers", "get_param", "has_param",
    "get_param_names", "search_param",
})
ROSAPI_PREFIX = "/rosapi/"


class Refused(Exception):
    """Not through the front door (``code`` says why: forbidden, invalid)."""

    def __init__(self, message: str, code: str = "forbidden") -> None:
        super().__init__(message)
        self.message = message
        self.code = code


def rosapi_type(service: str) -> str | None:
    """rosapi's type for one of its read-only services (``/rosapi/topics`` -> ``rosapi/Topics``), else None."""
    if not service.startswith(ROSAPI_PREFIX):
        return None
    name = service.removeprefix(ROSAPI_PREFIX)
    if name not in ROSAPI_READ_ONLY:
        return None
    return "rosapi/" + "".join(part.capitalize() for part in name.split("_"))


def is_cmd_vel(topic: str) -> bool:
    return topic == ri.topic("cmd_vel").name


def _string_data(msg: Any) -> Any:
    if not isinstance(msg, dict) or set(msg) - {"data"}:
        raise Refused("a std_msgs/String message has one field, data", "invalid")
    return msg.get("data", "")


def publish_command(*, user: Any, topic: str, msg_type: str | None, msg: Any, allowed: set[str]) -> Command:
    """The command a publish on ``topic`` is, for the pipeline to run; Refused when there is none."""
    for action, (_, key, *_rest) in STRING_COMMANDS.items():
        if ri.topic(key).name == topic:
            return string_command(action, _string_data(msg))
    if topic == ri.topic("robot_mode").name:
        data = _string_data(msg)
        try:
            mode: Any = ri.Mode.from_short(data) if isinstance(data, str) else data
        except ValueError:
            mode = data  # the command's check names the modes there are
        return change_mode(mode, user=user)
    for key, build in (("move_base_simple_goal", goal_send), ("initialpose", _initial_pose)):
        if topic == ri.topic(key).name:
            return build(user=user, data=_planar_pose(msg, nested=key == "initialpose"))
    if topic in allowed:
        if not msg_type:
            raise Refused(f"advertise {topic} with its type before publishing on it", "invalid")
        if not isinstance(msg, dict):
            raise Refused("msg must be an object", "invalid")

        async def send(_: Any) -> str:
            await bus.arequest("publish", topic=topic, msg_type=msg_type, msg=msg)
            return f"Published on {topic}"

        return Command("frontdoor.publish", {"topic": topic, "type": msg_type}, send)
    raise Refused(f"Publishing on {topic} is not allowed through the front door (velocity on "
                  f"{ri.topic('cmd_vel').name}, the robot's command topics, navigation goals on "
                  f"{ri.topic('move_base_simple_goal').name}, and what an admin allows).")


def _initial_pose(*, user: Any, data: dict[str, Any]) -> Command:
    return initial_pose_set(data=data)


def _planar_pose(msg: Any, *, nested: bool) -> dict[str, Any]:
    """A ``PoseStamped`` (``PoseWithCovarianceStamped`` when ``nested``) in the map frame as the
    navigation commands' ``{x, y, yaw}``; they check it against the map."""
    if not isinstance(msg, dict) or not isinstance(msg.get("pose"), dict):
        raise Refused("msg must be a pose message with a pose", "invalid")
    pose = msg["pose"].get("pose") if nested else msg["pose"]
    header = msg.get("header")
    frame = header.get("frame_id", "") if isinstance(header, dict) else ""
    if frame not in ("", "map", "/map"):
        raise Refused(f"poses are taken in the map frame, not {frame!r}", "invalid")
    if not isinstance(pose, dict) or not isinstance(pose.get("position"), dict):
        raise Refused("msg must be a pose message with a position", "invalid")
    given = pose.get("orientation")
    orientation: dict[str, Any] = given if isinstance(given, dict) else {"w": 1.0}
    position: dict[str, Any] = pose["position"]
    return {"x": finite(position.get("x", 0.0), "position.x"), "y": finite(position.get("y", 0.0), "position.y"),
            "yaw": quaternion_to_yaw({k: finite(orientation.get(k, 0.0), f"orientation.{k}")
                                      for k in ("x", "y", "z", "w")})}


def call_command(*, service: str, service_type: str | None, args: dict[str, Any], allowed: set[str]) -> Command:
    """The command a call of ``service`` is (rosapi's read-only services are answered before this)."""
    for key, on in (("enable_motors", True), ("disable_motors", False)):
        if ri.service(key).name == service:
            return set_motors(on)
    if service in allowed:
        async def send(_: Any) -> str:
            reply = await bus.arequest("call_service", service=service, service_type=service_type or "", args=args)
            command.result["values"] = reply.get("values")
            return f"Called {service}"

        command = Command("frontdoor.call", {"service": service}, send)
        return command
    raise Refused(f"Calling {service} is not allowed through the front door (rosapi's read-only services, "
                  "the motor services, and what an admin allows).")


def drive_input(msg: Any) -> dict[str, Any]:
    """A ``geometry_msgs/Twist`` as the drive page's input: forward speed and turn rate as fractions of
    the server's limits (which cap them), so the same clamps, lock, deadman and latch apply."""
    if not isinstance(msg, dict):
        raise Refused("msg must be a geometry_msgs/Twist object", "invalid")
    linear, angular = msg.get("linear") or {}, msg.get("angular") or {}
    if not isinstance(linear, dict) or not isinstance(angular, dict):
        raise Refused("msg must be a geometry_msgs/Twist object", "invalid")
    x = finite(linear.get("x", 0.0), "linear.x")
    z = finite(angular.get("z", 0.0), "angular.z")
    limits = server_limits()
    return {"type": "input", "linear": x / limits.linear if limits.linear else 0.0,
            "angular": z / limits.angular if limits.angular else 0.0}
