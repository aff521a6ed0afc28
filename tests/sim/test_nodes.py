"""The simulator as composed nodes: each node's declared topics and services, and adding a node of one's own."""

from __future__ import annotations

from typing import Any

import pytest

from robot import interface as ri
from simulator import SimRobot, SimThread
from simulator.bus import Bus
from tests.sim.support import FAST, Raw, on_topic, wait_until

TEST_TOPIC = "/sim_test/heartbeat"
TEST_SERVICE = "/sim_test/echo"


class HeartbeatNode:
    """A node as another module would write one: a periodic topic, a service, a handler, a tick."""

    names = ("/sim_test_heartbeat",)
    publishes = ()
    answers = ()

    def __init__(self) -> None:
        self.started = self.stopped = 0
        self.ticks = 0
        self.cmd_vel: list[dict[str, Any]] = []

    def start(self, bus: Bus) -> None:
        self.started += 1
        bus.declare(TEST_TOPIC, "std_msgs/Int32")
        bus.answer_name(TEST_SERVICE, "rosapi/GetParam", lambda r: {"value": r["name"].upper()})
        bus.on("cmd_vel", self.cmd_vel.append)
        bus.each_tick(self._step)
        bus.every(0.05, lambda: bus.publish_name(TEST_TOPIC, {"data": self.ticks}))

    def _step(self, now: float, dt: float) -> None:
        self.ticks += 1

    def stop(self) -> None:
        self.stopped += 1


def test_every_node_declares_interface_keys_and_is_listed_by_rosapi() -> None:
    robot = SimRobot(port=0, video_port=0)
    assert len(robot.nodes) >= 5
    for node in robot.nodes:
        for key in node.publishes:
            assert ri.topic(key).name, (node, key)
        for key in node.answers:
            assert ri.service(key).name, (node, key)
    names = [n for node in robot.nodes for n in node.names]
    assert len(names) == len(set(names))
    assert {"/RosAria", "/move_base", "/cyborg_controller", "/cyborg_audio", "/cyborg_commander",
            "/rosbridge_websocket"} <= set(names)


def test_an_added_node_is_started_ticked_reachable_and_stopped() -> None:
    sim = SimThread(**FAST)
    node = sim.robot.add(HeartbeatNode())
    with sim:
        assert node.started == 1
        raw = Raw(sim.url)
        try:
            assert "/sim_test_heartbeat" in raw.call(ri.service("rosapi_nodes").name)["values"]["nodes"]
            assert raw.call(TEST_SERVICE, {"name": "hello"}, cid="e")["values"] == {"value": "HELLO"}
            raw.send({"op": "subscribe", "id": "h", "topic": TEST_TOPIC, "type": "std_msgs/Int32"})
            first = raw.expect(on_topic(TEST_TOPIC))["msg"]["data"]
            wait_until(lambda: raw.expect(on_topic(TEST_TOPIC))["msg"]["data"] > first, what="ticks advance")
            cmd = {"linear": {"x": 0.1, "y": 0.0, "z": 0.0}, "angular": {"x": 0.0, "y": 0.0, "z": 0.0}}
            raw.send({"op": "publish", "topic": ri.topic("cmd_vel").name, "msg": cmd})
            wait_until(lambda: sim.call(lambda: len(node.cmd_vel)) == 1, what="cmd_vel handled by the node")
        finally:
            raw.close()
        with pytest.raises(RuntimeError):
            sim.call(lambda: sim.robot.add(HeartbeatNode()))
    assert node.stopped == 1
