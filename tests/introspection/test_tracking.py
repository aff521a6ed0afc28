"""Against the simulator: the link's trackers publish the state machine's graph, its active
states (from introspection, or from state_change without it) and the diagnostics by component."""

from __future__ import annotations

import asyncio
import time

from robot import interface as ri
from robot.introspection.tracking import track_diagnostics, track_smach
from robot.live.groups import DIAGNOSTICS_KEY, SMACH_ACTIVE_KEY, SMACH_GRAPH_KEY
from robot.live.state import get_store
from tests.conftest import EITHER_ROS
from tests.helpers import async_wait_until


def stored(key: str):
    entry = get_store().get_all().get(key)
    return entry["msg"] if entry else None


def leaves() -> list[str]:
    return (stored(SMACH_ACTIVE_KEY) or {}).get("leaves", [])


@EITHER_ROS
async def test_the_graph_and_its_active_state_follow_the_simulators_machine(link, sim):
    await async_wait_until(lambda: link.dial.ros_version == sim.robot.ros, timeout=10, what="the link to find the ROS")
    task = asyncio.ensure_future(track_smach(link))
    try:
        # Each container publishes its own structure: the graph grows as they arrive.
        whole = ["/SM_ROOT", "/SM_ROOT/behaviour", "/SM_ROOT/behaviour/navigation"]
        graph = await async_wait_until(lambda: (stored(SMACH_GRAPH_KEY) or {}).get("containers") == whole
                                       and stored(SMACH_GRAPH_KEY), timeout=15, what="the whole graph")
        await async_wait_until(lambda: leaves() == ["/SM_ROOT/suspension"], timeout=10, what="suspension")
        assert stored(SMACH_ACTIVE_KEY)["source"] == "introspection"
        # The graph is stored first, then the active state on it.
        await async_wait_until(lambda: stored(SMACH_ACTIVE_KEY)["version"] == graph["version"], timeout=5,
                               what="the active state on the whole graph")
        sim.call(lambda: sim.robot.controller.fire("behaviour_start"))
        await async_wait_until(lambda: leaves() == ["/SM_ROOT/behaviour/idle"], timeout=10, what="idle")
        active = stored(SMACH_ACTIVE_KEY)
        assert active["active"] == ["/SM_ROOT/behaviour", "/SM_ROOT/behaviour/idle"]
        assert {"bedtime", "suspend"} <= {t["event"] for t in active["transitions"]}
    finally:
        task.cancel()
        sim.call(lambda: sim.robot.controller.fire("suspend"))  # back where the simulator started


@EITHER_ROS
async def test_without_introspection_state_change_tells_the_active_state(link, sim):
    await async_wait_until(lambda: link.dial.ros_version == sim.robot.ros, timeout=10, what="the link to find the ROS")
    # fresh_s < 0: no container status ever counts, as on a robot without introspection.
    task = asyncio.ensure_future(track_smach(link, fresh_s=-1))
    try:
        await async_wait_until(lambda: stored(SMACH_GRAPH_KEY), timeout=15, what="the graph")
        # state_change is sent on transitions only: the one that ended the start-up may predate the link.
        await async_wait_until(lambda: sim.snapshot()["state"]["smach_state"] == "suspension", timeout=10)
        sim.call(lambda: sim.robot.controller.fire("manual_start"))
        await async_wait_until(lambda: leaves() == ["/SM_ROOT/manual"], timeout=10, what="manual")
        assert stored(SMACH_ACTIVE_KEY)["source"] == "state_change"
    finally:
        task.cancel()
        sim.call(lambda: sim.robot.controller.fire("aborted"))


def _diagnostic(name: str, level: int, message: str) -> dict:
    return {"header": {}, "status": [{"level": level, "name": name, "message": message, "hardware_id": "test",
                                      "values": [{"key": "k", "value": message}]}]}


@EITHER_ROS
async def test_diagnostics_are_kept_by_component_and_a_level_change_shows_at_once(link, sim):
    await async_wait_until(lambda: link.dial.ros_version == sim.robot.ros, timeout=10, what="the link to find the ROS")
    task = asyncio.ensure_future(track_diagnostics(link, refresh_s=30))
    topic = ri.topic("diagnostics").name

    def component(name: str) -> dict:
        return next((c for c in (stored(DIAGNOSTICS_KEY) or {}).get("components", []) if c["name"] == name), {})

    try:
        await async_wait_until(lambda: sim.subscription_count(topic), timeout=10, what="the link's subscription")
        sim.call(lambda: sim.robot.publish_external(topic, _diagnostic("test: arm", 0, "fine")))
        sim.call(lambda: sim.robot.publish_external(topic, _diagnostic("test: gripper", 1, "slipping")))
        await async_wait_until(lambda: component("test: gripper").get("level") == 1, timeout=10, what="gripper")
        assert component("test: arm")["message"] == "fine"  # reported apart, kept together
        # A new level is published at once, well before the (here long) refresh period.
        sim.call(lambda: sim.robot.publish_external(topic, _diagnostic("test: arm", 2, "jammed")))
        await async_wait_until(lambda: component("test: arm").get("level") == 2, timeout=10, what="arm error")
        assert stored(DIAGNOSTICS_KEY)["worst_name"] == "ERROR"
    finally:
        task.cancel()


class _Listeners:
    """All of the link that the trackers use: the list of message listeners."""

    def __init__(self) -> None:
        self.listeners: list = []

    def hear(self, name: str, msg: dict) -> None:
        for listener in list(self.listeners):
            listener(name, "", msg, time.time())


def _container(path: str, children: list[str]) -> dict:
    return {"path": path, "children": children, "internal_outcomes": [], "outcomes_from": [],
            "outcomes_to": [], "container_outcomes": []}


async def test_a_grown_graph_re_tells_the_active_state_with_its_version():
    link = _Listeners()
    task = asyncio.ensure_future(track_smach(link))  # type: ignore[arg-type]
    try:
        await async_wait_until(lambda: link.listeners, timeout=5, what="the tracker listening")
        link.hear(ri.topic("smach_structure").name, _container("/SM_ROOT", ["suspension", "behaviour"]))
        link.hear(ri.topic("smach_status").name, {"path": "/SM_ROOT", "active_states": ["suspension"]})
        await async_wait_until(lambda: leaves() == ["/SM_ROOT/suspension"], timeout=5, what="suspension")
        first = stored(SMACH_GRAPH_KEY)["version"]
        # Another container's structure arrives; the active state itself does not move.
        link.hear(ri.topic("smach_structure").name, _container("/SM_ROOT/behaviour", ["idle"]))
        await async_wait_until(lambda: stored(SMACH_GRAPH_KEY)["version"] != first, timeout=5, what="grown graph")
        grown = stored(SMACH_GRAPH_KEY)["version"]
        # Well within the 5 s after which the status would go stale and change the active state anyway.
        await async_wait_until(lambda: stored(SMACH_ACTIVE_KEY)["version"] == grown, timeout=2,
                               what="the active state on the grown graph")
    finally:
        task.cancel()
