"""actionlib servers over topics (``<ns>/goal``, ``/cancel`` in; ``/status``, ``/feedback``,
``/result`` out), as a ROS 1 SimpleActionServer behaves: a new goal preempts the current one.

``Ros2Action`` puts the same server behind ROS 2's rosbridge action ops (``send_action_goal``,
``cancel_action_goal`` in; ``action_feedback``, ``action_result`` out), its goal status on
``<ns>/_action/status`` and its cancel service on ``<ns>/_action/cancel_goal``."""

from __future__ import annotations

import base64
import hashlib
import itertools
import time
import uuid
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from . import messages
from .protocol import ActionEndpoint, Client

PENDING, ACTIVE, PREEMPTED, SUCCEEDED, ABORTED, REJECTED = 0, 1, 2, 3, 4, 5
TERMINAL = frozenset({PREEMPTED, SUCCEEDED, ABORTED, REJECTED, 8, 9})
STATUS_KEEP_S = 5.0  # actionlib's status_list_timeout


@dataclass
class Goal:
    id: str
    stamp: dict[str, int]
    goal: dict[str, Any]
    status: int = PENDING
    text: str = ""
    finished_at: float = 0.0
    data: dict[str, Any] = field(default_factory=dict)

    def goal_status(self) -> dict[str, Any]:
        return {"goal_id": {"stamp": self.stamp, "id": self.id}, "status": self.status, "text": self.text}


class ActionServer:
    """Callbacks: ``on_goal(goal)`` when a goal becomes active, ``on_cancel(goal)`` when the
    active goal is preempted (by a cancel or a newer goal)."""

    def __init__(self, name: str, action_type: str, publish: Callable[[str, dict[str, Any]], None],
                 on_goal: Callable[[Goal], None], on_cancel: Callable[[Goal], None]) -> None:
        self.name = name
        self.type = action_type
        self.publish = publish
        self.on_goal = on_goal
        self.on_cancel = on_cancel
        self.status_topic = f"{name}/status"
        self.goals: dict[str, Goal] = {}
        self.current: Goal | None = None
        self._ids = itertools.count(1)

    @property
    def topics(self) -> dict[str, str]:
        t = self.type
        return {f"{self.name}/goal": f"{t}ActionGoal", f"{self.name}/cancel": "actionlib_msgs/GoalID",
                f"{self.name}/status": "actionlib_msgs/GoalStatusArray",
                f"{self.name}/feedback": f"{t}ActionFeedback", f"{self.name}/result": f"{t}ActionResult"}

    def new_goal_id(self) -> str:
        return f"{self.name.strip('/').replace('/', '_')}-{next(self._ids)}-{time.time():.3f}"

    def receive_goal(self, action_goal: dict[str, Any]) -> Goal:
        gid = action_goal["goal_id"]
        stamp = gid["stamp"] if gid["stamp"]["secs"] or gid["stamp"]["nsecs"] else messages.stamp()
        goal = Goal(gid["id"] or self.new_goal_id(), stamp, action_goal["goal"])
        self.goals[goal.id] = goal
        previous = self.current
        if previous is not None and previous.status == ACTIVE:
            self.finish(previous, PREEMPTED, "This goal was canceled because another goal was received")
            self.on_cancel(previous)
        goal.status = ACTIVE
        self.current = goal
        self.publish_status()
        self.on_goal(goal)
        return goal

    def receive_cancel(self, goal_id: dict[str, Any]) -> None:
        # actionlib: empty id and zero stamp cancel everything; a stamp cancels goals up to it.
        gid = goal_id.get("id", "")
        st = goal_id.get("stamp", {"secs": 0, "nsecs": 0})
        t = st["secs"] + st["nsecs"] * 1e-9
        for goal in list(self.goals.values()):
            if goal.status in TERMINAL:
                continue
            gt = goal.stamp["secs"] + goal.stamp["nsecs"] * 1e-9
            if (not gid and t == 0) or goal.id == gid or (t and gt <= t):
                was_current = goal is self.current
                self.finish(goal, PREEMPTED if goal.status == ACTIVE else 8, "canceled")
                if was_current:
                    self.on_cancel(goal)

    def feedback(self, goal: Goal, feedback: dict[str, Any]) -> None:
        self.publish(f"{self.name}/feedback", {"header": messages.header(), "status": goal.goal_status(),
                                               "feedback": feedback})

    def finish(self, goal: Goal, status: int, text: str = "", result: dict[str, Any] | None = None) -> None:
        if goal.status in TERMINAL:
            return
        goal.status, goal.text, goal.finished_at = status, text, time.monotonic()
        if goal is self.current:
            self.current = None
        if result is None:
            result = messages.default(f"{self.type}Result")
        self.publish(f"{self.name}/result", {"header": messages.header(), "status": goal.goal_status(),
                                             "result": result})
        self.publish_status()

    def status_message(self) -> dict[str, Any]:
        now = time.monotonic()
        for gid, goal in list(self.goals.items()):
            if goal.status in TERMINAL and now - goal.finished_at > STATUS_KEEP_S:
                del self.goals[gid]
        return {"header": messages.header(), "status_list": [g.goal_status() for g in self.goals.values()]}

    def publish_status(self) -> None:
        self.publish(self.status_topic, self.status_message())


# actionlib's status -> action_msgs/GoalStatus (1 ACCEPTED, 2 EXECUTING, 3 CANCELING, 4 SUCCEEDED,
# 5 CANCELED, 6 ABORTED; a rejected goal never gets a status there)
ROS2_STATUS = {PENDING: 1, ACTIVE: 2, PREEMPTED: 5, SUCCEEDED: 4, ABORTED: 6, REJECTED: 6, 6: 3, 7: 3, 8: 5, 9: 6}
ZERO_UUID = base64.b64encode(bytes(16)).decode()
CANCEL_OK, CANCEL_REJECTED, CANCEL_UNKNOWN_GOAL = 0, 1, 2


def goal_uuid(goal_id: str) -> str:
    """The goal's UUID as rosbridge sends a uint8[16] (base64); goals the robot's nodes send get one too."""
    try:
        raw = bytes.fromhex(goal_id)
    except ValueError:
        raw = b""
    return base64.b64encode(raw if len(raw) == 16 else hashlib.md5(goal_id.encode()).digest()).decode()


class Ros2Action(ActionEndpoint):
    """``server`` as a ROS 2 action: ``goal_in`` turns a goal into the server's, ``feedback_out`` the
    server's feedback into the action's."""

    def __init__(self, server: ActionServer, wire_type: str, publish: Callable[[str, dict[str, Any], bool], None],
                 goal_in: Callable[[dict[str, Any]], dict[str, Any]] = lambda g: g,
                 feedback_out: Callable[[Goal, dict[str, Any]], dict[str, Any]] = lambda goal, f: f) -> None:
        self.server, self.type, self._publish_topic = server, wire_type, publish
        self.goal_in, self.feedback_out = goal_in, feedback_out
        self.owners: dict[str, tuple[Client, Any]] = {}  # goal id -> the client and op id that sent it
        server.publish = self._publish
        server.status_topic = f"{server.name}/_action/status"
        self.cancel_service = f"{server.name}/_action/cancel_goal"

    def send_goal(self, client: Client, op_id: Any, args: dict[str, Any]) -> None:
        goal = messages.normalize(f"{self.server.type}Goal", args)
        gid = uuid.uuid4().hex
        self.owners[gid] = (client, op_id)
        self.server.receive_goal({"goal_id": {"stamp": messages.stamp(), "id": gid}, "goal": self.goal_in(goal)})

    def cancel_goal(self, client: Client, op_id: Any) -> None:
        for gid, owner in list(self.owners.items()):
            if owner == (client, op_id):
                self.server.receive_cancel({"id": gid, "stamp": {"secs": 0, "nsecs": 0}})

    def cancel_service_call(self, request: dict[str, Any]) -> dict[str, Any]:
        """action_msgs/CancelGoal: a zero UUID and stamp cancel every goal, a stamp those up to it."""
        info = request["goal_info"]
        wanted, stamp = info["goal_id"]["uuid"], info["stamp"]
        live = [g for g in self.server.goals.values() if g.status not in TERMINAL]
        if wanted == ZERO_UUID:
            gid = ""
        else:
            gid = next((g.id for g in live if goal_uuid(g.id) == wanted), "")
            if not gid and not (stamp["secs"] or stamp["nsecs"]):
                return {"return_code": CANCEL_UNKNOWN_GOAL, "goals_canceling": []}
        self.server.receive_cancel({"id": gid, "stamp": stamp})
        canceled = [g for g in live if g.status in TERMINAL]
        return {"return_code": CANCEL_OK if canceled else CANCEL_REJECTED,
                "goals_canceling": [{"goal_id": {"uuid": goal_uuid(g.id)}, "stamp": g.stamp} for g in canceled]}

    def _publish(self, name: str, msg: dict[str, Any]) -> None:
        if name == self.server.status_topic:
            self._publish_topic(name, {"status_list": [
                {"goal_info": {"goal_id": {"uuid": goal_uuid(s["goal_id"]["id"])}, "stamp": s["goal_id"]["stamp"]},
                 "status": ROS2_STATUS[s["status"]]} for s in msg["status_list"]]}, True)
            return
        gid = msg["status"]["goal_id"]["id"]
        kind = name.rsplit("/", 1)[-1]
        if kind == "feedback":
            owner = self.owners.get(gid)
            if owner is not None:
                values = self.feedback_out(self.server.goals[gid], msg["feedback"])
                owner[0].reply({"op": "action_feedback", "id": owner[1], "action": self.server.name,
                                "values": values})
        elif kind == "result":
            owner = self.owners.pop(gid, None)
            if owner is not None:
                client, op_id = owner
                client.reply({"op": "action_result", "id": op_id, "action": self.server.name,
                              "values": msg["result"], "status": ROS2_STATUS[msg["status"]["status"]],
                              "result": True})
                client.release(("goal", op_id))
