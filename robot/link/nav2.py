"""ROS 2 actions (Nav2's NavigateToPose, the navigation orders) behind the model's actionlib goals.

Above the link a goal is a publish on ``<action>/goal`` and a cancel one on ``<action>/cancel``
(the ROS 1 robot's actionlib). On a ROS 2 robot the link turns them into what its rosbridge takes:
the goal as ``send_action_goal`` on a connection of its own (rosbridge 2.x by default handles a
client's next frame only after its goal ends: on the link's socket a goal would hold back every
publish, the E-STOP's zero included), and every cancel as a call of the hidden
``<action>/_action/cancel_goal`` service (a ``cancel_action_goal`` on the goal's socket would wait
for the goal to end). Goal status comes from ``<action>/_action/status``; the UUID rosbridge gave
our goal is learnt there (the first new goal after ours was sent) and shown under our id. The goal's
feedback (distance and time remaining) and result reach the model as that goal's status and its text.
"""

from __future__ import annotations

import collections
import threading
import time
from collections.abc import Callable, Mapping
from typing import Any

import roslibpy

from robot import interface as ri
from robot.link.dialect import GOAL_STATUS_FROM_ROS2
from robot.link.rosclient import LinkRos, call_service, close_quietly
from robot.live.groups import LinkReply

ZERO_UUID = [0] * 16
NAV2_TYPE = "nav2_msgs/action/NavigateToPose"


def action_of(topic: str) -> tuple[ri.Action, str] | None:
    """(the ROS 2 action, ``goal`` or ``cancel``) when ``topic`` is one of an action's inputs, by either
    ROS's name: a web process that has not heard which ROS the robot runs names it as ROS 1 does."""
    for ros in ri.ROS_VERSIONS:
        for action in ri.actions(ros):
            for suffix in ("goal", "cancel"):
                if topic == f"{action.name}/{suffix}":
                    return ri.action(action.key, ri.ROS2), suffix
    return None


def goal_args(action: ri.Action, goal: dict[str, Any]) -> dict[str, Any]:
    """The actionlib goal's content as the ROS 2 action's goal."""
    if action.type == NAV2_TYPE:
        return {"pose": goal["target_pose"], "behavior_tree": ""}
    return goal


def progress_text(feedback: dict[str, Any]) -> str:
    """What NavigateToPose's feedback says about the way left, for people."""
    left = feedback.get("estimated_time_remaining") or {}
    seconds = float(left.get("sec", 0) or 0) + float(left.get("nanosec", 0) or 0) / 1e9
    if "distance_remaining" not in feedback:
        return ""
    return f"{float(feedback['distance_remaining']):.1f} m to go, about {seconds:.0f} s"


def foreign_uuid(goal_id: str) -> bytes | None:
    """The UUID of a goal another tool sent, as the model names it (its hex); None for any other id."""
    try:
        raw = bytes.fromhex(goal_id)
    except ValueError:
        return None
    return raw if len(raw) == 16 else None


def cancel_request(uuid: list[int] | None, before: float | None = None) -> dict[str, Any]:
    """action_msgs/CancelGoal: a zero UUID and stamp cancel every goal; a zero UUID and a stamp, those
    accepted up to it; a UUID, that goal."""
    sec = int(before or 0)
    return {"goal_info": {"goal_id": {"uuid": uuid or ZERO_UUID},
                          "stamp": {"sec": sec, "nanosec": int(((before or 0) - sec) * 1e9)}}}


class Ros2Goals:
    """The link's ROS 2 goals: ``url`` is the robot's rosbridge, ``ros`` the link's own connection."""

    def __init__(self, url: str, ros: Callable[[], roslibpy.Ros | None], timeout_s: float) -> None:
        self.url = url
        self.ros = ros
        self.timeout_s = timeout_s
        self.uuids: dict[str, str] = {}  # rosbridge's UUID (hex) -> our goal id
        # Per action status topic, our goals whose UUID is not known yet: (sent at, our id).
        self._unmatched: collections.defaultdict[str, collections.deque[tuple[float, str]]] = \
            collections.defaultdict(collections.deque)
        self._listed: collections.defaultdict[str, set[str]] = collections.defaultdict(set)  # the last status's UUIDs
        self._connections: dict[str, roslibpy.Ros] = {}
        # Where a goal's status in the model goes (the link's own message path; from the reactor's thread).
        self.on_status: Callable[[dict[str, Any]], None] = lambda msg: None

    async def publish(self, topic: str, msg: dict[str, Any]) -> LinkReply | None:
        """The ROS 2 way of a publish on an action's goal or cancel topic; None for any other topic."""
        found = action_of(topic)
        if found is None:
            return None
        action, suffix = found
        if suffix == "goal":
            return self._send(action, str(msg["goal_id"]["id"]), msg["goal"])
        goal_id = str(msg.get("id") or "")
        uuid = next((bytes.fromhex(u) for u, ours in self.uuids.items() if ours == goal_id), None) if goal_id else None
        if uuid is None and goal_id:
            uuid = foreign_uuid(goal_id)
        request = cancel_request(list(uuid) if uuid else None, time.time() if goal_id and not uuid else None)
        ros = self.ros()
        if ros is None:
            return {"ok": False, "error_code": "offline", "error": "robot offline"}
        reply = await call_service(ros, action.name + ri.ACTION_CANCEL_SUFFIX, ri.ACTION_CANCEL_TYPE, request,
                                   self.timeout_s)
        return {"ok": True} if reply["ok"] else reply

    def _send(self, action: ri.Action, goal_id: str, goal: dict[str, Any]) -> LinkReply:
        ros = LinkRos(self.url)
        self._connections[goal_id] = ros
        self._unmatched[action.name + ri.ACTION_STATUS_SUFFIX].append((time.time(), goal_id))

        def status(code: int, text: str) -> None:
            self.on_status({"status_list": [{"goal_id": {"id": goal_id, "stamp": {"secs": 0, "nsecs": 0}},
                                             "status": code, "text": text}]})

        def feedback(values: Any) -> None:
            if goal_id in self._connections:
                status(1, progress_text(dict(values)))

        def done(result: Any) -> None:
            self._connections.pop(goal_id, None)
            close_quietly_later(ros)
            code = result.get("status") if isinstance(result, Mapping) else None  # errback: a text
            if code is not None:
                status(GOAL_STATUS_FROM_ROS2.get(int(getattr(code, "value", code) or 0), 9), "")

        roslibpy.ActionClient(ros, action.name, action.type).send_goal(
            roslibpy.Goal(goal_args(action, goal)), done, feedback, done)
        return {"ok": True}

    def name_goals(self, msg: dict[str, Any], status_topic: str) -> dict[str, Any]:
        """A status message in the model, our goals under our ids (learning rosbridge's UUIDs for them: a
        goal listed before, another tool's, is never taken for ours)."""
        unmatched = self._unmatched[status_topic]
        ours = set(self.uuids.values()) | {gid for _, gid in unmatched}
        listed_before = self._listed[status_topic]
        self._listed[status_topic] = {s["goal_id"]["id"] for s in msg.get("status_list", [])}
        for status in msg.get("status_list", []):
            gid = status["goal_id"]["id"]
            if gid in ours:
                continue
            if gid not in self.uuids and gid not in listed_before and unmatched and status["status"] in (0, 1):
                self.uuids[gid] = unmatched.popleft()[1]
            if gid in self.uuids:
                status["goal_id"]["id"] = self.uuids[gid]
        return msg

    def close(self) -> None:
        for ros in self._connections.values():
            close_quietly_later(ros)
        self._connections.clear()


def close_quietly_later(ros: roslibpy.Ros) -> None:
    """Close a goal's connection off the reactor's thread (closing blocks until the reactor has done it)."""
    threading.Thread(target=close_quietly, args=(ros,), daemon=True).start()
