"""actionlib servers over topics (``<ns>/goal``, ``/cancel`` in; ``/status``, ``/feedback``,
``/result`` out), as a ROS 1 SimpleActionServer behaves: a new goal preempts the current one.

``Ros2Action`` is the same server behind ROS 2's rosbridge action ops (``send_action_goal``,
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

from robot import interface as ri

from . import messages
from .bus import ActionEndpoint, Bus, Peer

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

    bus: Bus

    def __init__(self, name: str, action_type: str, on_goal: Callable[[Goal], None],
                 on_cancel: Callable[[Goal], None]) -> None:
        self.name = name
        self.type = action_type
        self.on_goal = on_goal
        self.on_cancel = on_cancel
        self.status_topic = f"{name}/status"
        self.goals: dict[str, Goal] = {}
        self.current: Goal | None = None
        self._ids = itertools.count(1)

    def install(self, bus: Bus) -> None:
        """Declare the action's topics and take goals and cancels from them."""
        self.bus, n, t = bus, self.name, self.type
        for name, msg_type in {f"{n}/goal": f"{t}ActionGoal", f"{n}/cancel": "actionlib_msgs/GoalID",
                               self.status_topic: "actionlib_msgs/GoalStatusArray",
                               f"{n}/feedback": f"{t}ActionFeedback", f"{n}/result": f"{t}ActionResult"}.items():
            bus.declare(name, msg_type)
        bus.on_name(f"{n}/goal", self.receive_goal)
        bus.on_name(f"{n}/cancel", self.receive_cancel)

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
        self.bus.publish_name(f"{self.name}/feedback", {"header": messages.header(), "status": goal.goal_status(),
                                                        "feedback": feedback})

    def send_result(self, goal: Goal, result: dict[str, Any]) -> None:
        self.bus.publish_name(f"{self.name}/result", {"header": messages.header(), "status": goal.goal_status(),
                                                      "result": result})

    def finish(self, goal: Goal, status: int, text: str = "", result: dict[str, Any] | None = None) -> None:
        if goal.status in TERMINAL:
            return
        goal.status, goal.text, goal.finished_at = status, text, time.monotonic()
        if goal is self.current:
            self.current = None
        if result is None:
            result = messages.default(f"{self.type}Result")
        self.send_result(goal, result)
        self.publish_status()

    def status_message(self) -> dict[str, Any]:
        now = time.monotonic()
        for gid, goal in list(self.goals.items()):
            if goal.status in TERMINAL and now - goal.finished_at > STATUS_KEEP_S:
                del self.goals[gid]
        return {"header": messages.header(), "status_list": [g.goal_status() for g in self.goals.values()]}

    def publish_status(self) -> None:
        self.bus.publish_name(self.status_topic, self.status_message())


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


class Ros2Action(ActionServer, ActionEndpoint):
    """The server as a ROS 2 action: ``goal_in`` turns a goal into the server's, ``feedback_out`` the
    server's feedback into the action's."""

    def __init__(self, name: str, action_type: str, on_goal: Callable[[Goal], None],
                 on_cancel: Callable[[Goal], None], goal_in: Callable[[dict[str, Any]], dict[str, Any]] = lambda g: g,
                 feedback_out: Callable[[Goal, dict[str, Any]], dict[str, Any]] = lambda goal, f: f) -> None:
        super().__init__(name, action_type, on_goal, on_cancel)
        self.goal_in, self.feedback_out = goal_in, feedback_out
        self.owners: dict[str, tuple[Peer, Any]] = {}  # goal id -> the client and op id that sent it
        self.status_topic = f"{name}/_action/status"

    def install(self, bus: Bus) -> None:
        """Take goals from rosbridge's action ops; declare the status topic and answer the cancel service."""
        self.bus = bus
        bus.actions[self.name] = self
        bus.declare(self.status_topic, ri.ACTION_STATUS_TYPE)
        bus.answer_name(f"{self.name}/_action/cancel_goal", ri.ACTION_CANCEL_TYPE, self.cancel_service_call)

    def send_goal(self, client: Peer, op_id: Any, args: dict[str, Any]) -> None:
        goal = messages.normalize(f"{self.type}Goal", args)
        gid = uuid.uuid4().hex
        self.owners[gid] = (client, op_id)
        self.receive_goal({"goal_id": {"stamp": messages.stamp(), "id": gid}, "goal": self.goal_in(goal)})

    def cancel_goal(self, client: Peer, op_id: Any) -> None:
        for gid, owner in list(self.owners.items()):
            if owner == (client, op_id):
                self.receive_cancel({"id": gid, "stamp": {"secs": 0, "nsecs": 0}})

    def cancel_service_call(self, request: dict[str, Any]) -> dict[str, Any]:
        """action_msgs/CancelGoal: a zero UUID and stamp cancel every goal, a stamp those up to it."""
        info = request["goal_info"]
        wanted, stamp = info["goal_id"]["uuid"], info["stamp"]
        live = [g for g in self.goals.values() if g.status not in TERMINAL]
        if wanted == ZERO_UUID:
            gid = ""
        else:
            gid = next((g.id for g in live if goal_uuid(g.id) == wanted), "")
            if not gid and not (stamp["secs"] or stamp["nsecs"]):
                return {"return_code": CANCEL_UNKNOWN_GOAL, "goals_canceling": []}
        self.receive_cancel({"id": gid, "stamp": stamp})
        canceled = [g for g in live if g.status in TERMINAL]
        return {"return_code": CANCEL_OK if canceled else CANCEL_REJECTED,
                "goals_canceling": [{"goal_id": {"uuid": goal_uuid(g.id)}, "stamp": g.stamp} for g in canceled]}

    def publish_status(self) -> None:
        self.bus.publish_name(self.status_topic, {"status_list": [
            {"goal_info": {"goal_id": {"uuid": goal_uuid(s["goal_id"]["id"])}, "stamp": s["goal_id"]["stamp"]},
             "status": ROS2_STATUS[s["status"]]} for s in self.status_message()["status_list"]]}, latch=True)

    def feedback(self, goal: Goal, feedback: dict[str, Any]) -> None:
        owner = self.owners.get(goal.id)
        if owner is not None:
            owner[0].reply({"op": "action_feedback", "id": owner[1], "action": self.name,
                            "values": self.feedback_out(goal, feedback)})

    def send_result(self, goal: Goal, result: dict[str, Any]) -> None:
        owner = self.owners.pop(goal.id, None)
        if owner is not None:
            client, op_id = owner
            client.reply({"op": "action_result", "id": op_id, "action": self.name, "values": result,
                          "status": ROS2_STATUS[goal.status], "result": True})
            client.release(("goal", op_id))
