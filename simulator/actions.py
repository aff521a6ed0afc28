"""actionlib servers over topics (``<ns>/goal``, ``/cancel`` in; ``/status``, ``/feedback``,
``/result`` out), as a ROS 1 SimpleActionServer behaves: a new goal preempts the current one."""

from __future__ import annotations

import itertools
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from . import messages

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
        self.publish(f"{self.name}/status", self.status_message())
