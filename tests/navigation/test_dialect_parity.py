"""One scenario against the ROS 1 and the ROS 2 simulator gives the same API answers: nothing above the
link knows which ROS the robot runs. Dropped is only what legitimately differs: times, ids, the ``ros`` field,
the robot's readings (compared by their fields), and the two texts ROS 2's messages do not carry. One test
runs both robots in turn (the same fixtures), so the two answers meet in one place whatever the workers."""

from __future__ import annotations

import json
import re
import time
from typing import Any

import pytest
from asgiref.sync import async_to_sync

from robot import interface as ri
from robot.live.state import get_store
from robot.models import Location
from robot.navigation.status import GOAL_ID_PREFIX
from simulator.harness import SimThread
from tests.conftest import _empty_redis
from tests.helpers import wait_until
from tests.navigation.conftest import linked, wait_goal_state

pytestmark = pytest.mark.django_db(transaction=True)

DROPPED = frozenset({"id", "sent", "t", "at", "age_s", "ros", "received", "heard_at", "since", "stamp", "released_at",
                     "pressed_at", "connecting_until", "attempts", "convert_ms", "render_ms", "version", "map_version",
                     "link_alive", "url",
                     # ROS 2's GoalStatus has no text (its feedback's way left is shown instead), and its Log no topics.
                     "status_text", "topics"})
TIMES_AND_IDS = re.compile(rf"\d{{4}}-\d\d-\d\d \d\d:\d\d:\d\d \w+|\d+ ms|{GOAL_ID_PREFIX}[0-9a-f]+")
# What the robot publishes steadily: the state answer is compared once all of it arrived.
STEADY_KEYS = ("battery_soc", "battery_voltage", "battery_recharge_state", "bumper_state", "current_location",
               "emotion_system_status", "emotional_state", "motors_state", "robot_pose", "smach_status",
               "state_transitions")


def normalised(answer: Any) -> Any:
    """The answer without what legitimately differs between two runs and two dialects."""
    if isinstance(answer, dict):
        return {k: normalised(v) for k, v in answer.items() if k not in DROPPED}
    if isinstance(answer, list):
        return [normalised(v) for v in answer]
    if isinstance(answer, float):
        return round(answer, 1)
    if isinstance(answer, str):
        return TIMES_AND_IDS.sub("…", answer)
    return answer


def shape(value: Any) -> Any:
    """A live value's structure (its field names and kinds): the robot's readings differ from run to run."""
    if isinstance(value, dict):
        return {k: shape(v) for k, v in value.items() if k not in DROPPED}
    if isinstance(value, list):
        return [shape(value[0])] if value else []
    return type(value).__name__


def topic_list(topics: list[dict[str, Any]]) -> dict[str, Any]:
    """The topics answer for the topics the product knows, by its names for them (the interface's keys):
    each listed with the type configured for that ROS (the Topics page shows the robot's own types), and
    whether the product holds a subscription to it."""
    known = {t.name: t for t in ri.topics()}
    return {known[t["name"]].key: {"configured_type": t["type"] == known[t["name"]].type,
                                   "subscribed": t["subscribed"]} for t in topics if t["name"] in known}


def scenario(sim: SimThread, api) -> dict[str, Any]:
    answers: dict[str, Any] = {}
    # Messages with a header that arrived before the link found out the robot's ROS are as the robot sent
    # them (the link reads a robot as ROS 1 until then): the state is read once each is newer.
    found = time.time()

    def ready(s: dict[str, Any]) -> bool:
        values = s["values"]
        return s["connected"] and all(k in values and ("header" not in values[k]["value"] or values[k]["t"] > found)
                                      for k in STEADY_KEYS)

    state = wait_until(lambda: (s := api.get("/api/robot/state/").json()) and ready(s) and s, timeout=15,
                       what="the robot's state")
    answers["state"] = {"connected": state["connected"], "command_path": state["command_path"],
                        "link": normalised(state["link"]),
                        "values": {k: shape(state["values"][k]) for k in STEADY_KEYS},
                        "available_events": state["available_events"], "mode": normalised(state["mode"])}
    answers["topics"] = topic_list(api.get("/api/topics/").json()["topics"])

    before = time.time()
    goal = api.post("/api/navigation/goal/", {"x": 1.0, "y": -2.0, "yaw": 0.5}, format="json")
    answers["goal"] = (goal.status_code, normalised(goal.json()))
    wait_goal_state(api, "succeeded")
    # Away from reception, where the robot started (the robot says so at its next location report).
    done = wait_until(lambda: (s := api.get("/api/navigation/status/").json())["current_location"] == "" and s,
                      what="the robot to report it left reception")
    answers["goal_done"] = normalised({**done, "robot_pose": None})
    # The log console's entries since the goal was sent, as the product keeps them: who logged at which
    # level, and each entry's fields (how often a planner logs depends on the machine's pace).
    log = [e["msg"] for e in async_to_sync(get_store().aget_recent)("rosout") if e["t"] >= before]
    assert log, "the robot logged nothing about the goal"
    answers["log"] = sorted({(e["level"], e["name"], json.dumps(shape(e), sort_keys=True)) for e in log})

    Location.objects.create(name="stage", x=6.5, y=-1.0)
    go = api.post("/api/locations/stage/go/")
    answers["location_goal"] = (go.status_code, normalised(go.json()))
    wait_goal_state(api, "active")
    answers["location_active"] = normalised(api.get("/api/navigation/status/").json()["goal"])
    cancel = api.post("/api/navigation/cancel/", format="json")
    answers["cancel"] = (cancel.status_code, normalised({**cancel.json(), "goal": None, "robot_pose": None}))
    wait_goal_state(api, "cancelled")
    answers["cancelled"] = normalised({**api.get("/api/navigation/status/").json(), "robot_pose": None})

    press = api.post("/api/robot/estop/")
    # Its steps; what each did once all are done (a loaded machine may answer while some still try).
    answers["estop"] = [s["step"] for s in press.json()["steps"]]
    answers["estop_latch"] = normalised(wait_until(
        lambda: (latch := api.get("/api/robot/estop/").json()) and all(s["ok"] for s in latch["steps"]) and latch,
        what="every E-STOP step done"))
    release = api.post("/api/robot/estop/release/", {"confirm": True}, format="json")
    answers["release"] = (release.status_code, normalised(release.json()))
    answers["after_release"] = normalised(api.get("/api/robot/estop/").json())
    return answers


def test_one_scenario_gives_the_same_api_answers_on_either_ros(settings, operator_api):
    answers = {}
    for ros in ri.ROS_VERSIONS:
        _empty_redis()
        ri.reload()
        Location.objects.all().delete()
        with SimThread(port=0, video_port=0, startup_s=0.5, time_scale=4.0, ros=ros) as sim, linked(sim, settings):
            answers[ros] = scenario(sim, operator_api)
    for key in answers[ri.ROS1]:
        assert answers[ri.ROS2][key] == answers[ri.ROS1][key], key
