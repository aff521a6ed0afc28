"""Which ROS the robot runs, and what a ROS 2 robot says turned into the one model the product uses.

The product's model is the ROS 1 robot's (ROBOT_INTERFACE.md): stamps ``{secs, nsecs}``, /rosout
levels 1-16 with a header and a ``/``-named node, a PoseArray of particles, actionlib goal status
(``status_list[{goal_id{id, stamp}, status}]``, 3 SUCCEEDED, 4 ABORTED ...). A ROS 2 robot's
messages are translated here, where they come in, so nothing above the link knows which ROS.
"""

from __future__ import annotations

import base64
import json
from collections.abc import Callable
from typing import Any

import roslibpy

from robot import interface as ri
from robot.link.rosclient import call_service

# /rosapi/get_ros_version: only ROS 2's rosapi serves it.
ROS_VERSION_SERVICE = ("/rosapi/get_ros_version", "rosapi_msgs/srv/GetROSVersion")
MISSING_SERVICE = "does not exist"

# action_msgs/GoalStatus -> actionlib's: 1 ACCEPTED -> PENDING, 2 EXECUTING -> ACTIVE, 3 CANCELING ->
# PREEMPTING, 4 SUCCEEDED -> SUCCEEDED (3), 5 CANCELED -> PREEMPTED (2), 6 ABORTED -> ABORTED (4).
GOAL_STATUS_FROM_ROS2 = {0: 0, 1: 0, 2: 1, 3: 6, 4: 3, 5: 2, 6: 4}
# rcl_interfaces/Log levels 10..50 -> rosgraph_msgs/Log's 1..16
LOG_LEVEL_FROM_ROS2 = {10: 1, 20: 2, 30: 4, 40: 8, 50: 16}


def offers_version_service(ok: bool, values: Any) -> bool | None:
    """Whether rosapi's service list names /rosapi/get_ros_version (None: no list). Asked first, because
    calling a service that does not exist makes a ROS 1 rosbridge log an error on the robot's log."""
    if not ok or not isinstance(values, dict) or not isinstance(values.get("services"), list):
        return None
    return ROS_VERSION_SERVICE[0] in values["services"]


def version_from_answer(ok: bool, values: Any) -> int | None:
    """The robot's ROS from /rosapi/get_ros_version's answer; None if the answer says nothing
    (rosapi away, the call timed out)."""
    if ok and isinstance(values, dict) and values.get("version") in ri.ROS_VERSIONS:
        return int(values["version"])
    if not ok and MISSING_SERVICE in str(values):
        return ri.ROS1
    return None


async def ask_ros_version(ros: roslibpy.Ros, timeout_s: float) -> tuple[int | None, str]:
    """The ROS the robot runs, as its rosapi says (None and why when it does not say): the service list
    first, then /rosapi/get_ros_version if the list names it."""
    listing = ri.service("rosapi_services")
    listed = await call_service(ros, listing.name, listing.type, {}, timeout_s)
    if offers_version_service(listed["ok"], listed.get("values")) is False:
        return ri.ROS1, ""
    reply = await call_service(ros, *ROS_VERSION_SERVICE, {}, timeout_s)
    version = version_from_answer(reply["ok"], reply.get("values") if reply["ok"] else reply.get("error"))
    return version, str(reply.get("error") or listed.get("error") or "")


def goal_id_from_uuid(uuid: Any) -> str:
    """A ROS 2 goal's UUID (base64 or 16 ints, as rosbridge may send it) as the text id the model keeps."""
    raw = bytes(uuid) if isinstance(uuid, list) else base64.b64decode(str(uuid) or "")
    return raw.hex()


def _restamp(value: Any, frm: tuple[str, str], to: tuple[str, str], seq: bool) -> None:
    """Every stamp ``{frm}`` -> ``{to}`` wherever it is, and a header's ``seq`` given (0) or taken, in place
    (the message is ours to change); lists of numbers (ranges, cells) are not walked."""
    if isinstance(value, dict):
        if len(value) == 2 and frm[0] in value and frm[1] in value:
            value[to[0]], value[to[1]] = value.pop(frm[0]), value.pop(frm[1])
            return
        if "frame_id" in value and "stamp" in value:
            if seq:
                value.setdefault("seq", 0)
            else:
                value.pop("seq", None)
        for item in value.values():
            if isinstance(item, dict | list):
                _restamp(item, frm, to, seq)
    elif value and isinstance(value[0], dict | list):
        for item in value:
            _restamp(item, frm, to, seq)


def _stamps(value: Any) -> None:
    """``{sec, nanosec}`` -> ``{secs, nsecs}``, and a header gets ROS 1's ``seq`` (0)."""
    _restamp(value, ("sec", "nanosec"), ("secs", "nsecs"), seq=True)


def _log(msg: dict[str, Any]) -> dict[str, Any]:
    name = str(msg.get("name", ""))
    return {"header": {"seq": 0, "stamp": msg.get("stamp", {"secs": 0, "nsecs": 0}), "frame_id": ""},
            "level": LOG_LEVEL_FROM_ROS2.get(int(msg.get("level", 20)), 2),
            "name": name if name.startswith("/") else f"/{name}", "msg": msg.get("msg", ""),
            "file": msg.get("file", ""), "function": msg.get("function", ""), "line": msg.get("line", 0),
            "topics": []}


def _particles(msg: dict[str, Any]) -> dict[str, Any]:
    return {"header": msg.get("header", {}), "poses": [p.get("pose", {}) for p in msg.get("particles", [])]}


def _goal_status(msg: dict[str, Any]) -> dict[str, Any]:
    return {"header": {"seq": 0, "stamp": {"secs": 0, "nsecs": 0}, "frame_id": ""}, "status_list": [
        {"goal_id": {"id": goal_id_from_uuid(s["goal_info"]["goal_id"]["uuid"]), "stamp": s["goal_info"]["stamp"]},
         "status": GOAL_STATUS_FROM_ROS2.get(int(s["status"]), 9), "text": ""}
        for s in msg.get("status_list", [])]}


_BY_TYPE: dict[str, Callable[[dict[str, Any]], dict[str, Any]]] = {
    "rcl_interfaces/Log": _log,
    "nav2_msgs/ParticleCloud": _particles,
    "action_msgs/GoalStatusArray": _goal_status,
}


def to_model(ros: int, msg_type: str, msg: dict[str, Any]) -> dict[str, Any]:
    """A message as the product's model has it (the same message on a ROS 1 robot)."""
    if ros == ri.ROS1:
        return msg
    _stamps(msg)
    convert = _BY_TYPE.get(ri.ros1_spelling(msg_type))
    return convert(msg) if convert is not None else msg


# --- back to the robot's own, for exports ----------------------------------------------------
LOG_LEVEL_TO_ROS2 = {v: k for k, v in LOG_LEVEL_FROM_ROS2.items()}


def _ros2_stamps(value: Any) -> None:
    """``{secs, nsecs}`` -> ``{sec, nanosec}`` and headers without ``seq``: ``_stamps`` undone."""
    _restamp(value, ("secs", "nsecs"), ("sec", "nanosec"), seq=False)


def _ros2_log(msg: dict[str, Any]) -> dict[str, Any]:
    return {"stamp": (msg.get("header") or {}).get("stamp", {"secs": 0, "nsecs": 0}),
            "level": LOG_LEVEL_TO_ROS2.get(int(msg.get("level", 2)), 20), "name": str(msg.get("name", "")).lstrip("/"),
            "msg": msg.get("msg", ""), "file": msg.get("file", ""), "function": msg.get("function", ""),
            "line": msg.get("line", 0)}


def _ros2_particles(msg: dict[str, Any]) -> dict[str, Any]:
    poses = msg.get("poses") or []
    return {"header": msg.get("header", {}), "particles": [{"pose": p, "weight": 1.0 / len(poses)} for p in poses]}


_TO_ROS2: dict[str, Callable[[dict[str, Any]], dict[str, Any]]] = {
    "rcl_interfaces/Log": _ros2_log,
    "nav2_msgs/ParticleCloud": _ros2_particles,
}


def to_robot(msg_type: str, msg: Any) -> Any:
    """A message kept in the model as the robot that sent it has it, ``msg_type`` spelt its way: what an
    export of a ROS 2 robot's recording holds (stamps, log levels, particles; goal ids stay the model's)."""
    if not isinstance(msg, dict) or ri.ros1_spelling(msg_type) == msg_type:
        return msg
    convert = _TO_ROS2.get(ri.ros1_spelling(msg_type))
    out = convert(msg) if convert is not None else dict(msg)
    out = json.loads(json.dumps(out))  # a copy of our own to change in place
    _ros2_stamps(out)
    return out
