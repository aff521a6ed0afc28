"""A client doing what Foxglove's and Lichtblick's Rosbridge connection does (topics with full
definitions from rosapi, ROS 1 or 2 told by the log type, cbor-raw subscriptions, no throttle),
decoding with Foxglove's own deserializers under Node, field by field against what the robot
published (read straight from the simulator's rosbridge as JSON)."""

from __future__ import annotations

import base64
import json
import math
import shutil
import subprocess
import threading
import time
from pathlib import Path
from typing import Any

import cbor2
import pytest
from websockets.sync.client import connect

from robot import interface as ri
from simulator import SimThread
from tests.frontdoor.conftest import ticket_url

FOXGLOVE = Path(__file__).parent / "foxglove"


@pytest.fixture(autouse=True)
def _decoders_installed():
    if shutil.which("node") is None or not (FOXGLOVE / "node_modules").is_dir():
        pytest.fail("Foxglove's decoders are not installed: make test installs them (npm ci in "
                    "tests/frontdoor/foxglove)")


ODOM, BATTERY, SCAN = ri.topic("odom").name, ri.topic("battery_soc").name, ri.topic("scan").name
WINDOW_S = 4.0


def decode(ros: int, messages: list[dict[str, Any]]) -> list[dict[str, Any]]:
    done = subprocess.run(["node", str(FOXGLOVE / "decode.js")], input=json.dumps({"ros": ros, "messages": messages}),
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout)


def foxglove_session(url: str, topics: list[str], window_s: float,
                     ros: int = 1) -> tuple[dict[str, str], dict[str, list[dict]]]:
    """Foxglove's steps: topics and definitions, then cbor-raw subscriptions with no throttle. Returns the
    topics' types and full definitions, and per topic the frames' decoded CBOR (``msg``: secs, nsecs, bytes)."""
    got: dict[str, list[dict]] = {t: [] for t in topics}
    with connect(url, open_timeout=20, max_size=2**26) as ws:
        ws.send(json.dumps({"op": "call_service", "service": "/rosapi/topics_and_raw_types", "id": "types"}))
        while True:
            frame = json.loads(ws.recv(timeout=20))
            if frame.get("op") == "service_response":
                assert frame["result"], frame
                break
        values = frame["values"]
        # how Foxglove tells ROS 1 from ROS 2
        assert {1: "rosgraph_msgs/Log", 2: "rcl_interfaces/msg/Log"}[ros] in values["types"]
        definitions = dict(zip(values["topics"], zip(values["types"], values["typedefs_full_text"], strict=True),
                               strict=True))
        for topic in topics:
            ws.send(json.dumps({"op": "subscribe", "topic": topic, "type": definitions[topic][0],
                                "compression": "cbor-raw"}))
        deadline = time.monotonic() + window_s
        while (left := deadline - time.monotonic()) > 0:
            try:
                raw = ws.recv(timeout=left)
            except TimeoutError:
                break
            assert isinstance(raw, bytes), raw  # every publish as a binary CBOR frame
            frame = cbor2.loads(raw)
            got[frame["topic"]].append(frame["msg"])
    return {t: definitions[t] for t in topics}, got


def published(url: str, topics: list[str], window_s: float, out: dict[str, list[dict]]) -> None:
    """What the robot published, as JSON from its own rosbridge."""
    with connect(url, open_timeout=20, max_size=2**26) as ws:
        for topic in topics:
            ws.send(json.dumps({"op": "subscribe", "topic": topic}))
        deadline = time.monotonic() + window_s
        while (left := deadline - time.monotonic()) > 0:
            try:
                frame = json.loads(ws.recv(timeout=left))
            except TimeoutError:
                break
            if frame.get("op") == "publish" and frame["topic"] in out:
                out[frame["topic"]].append(frame["msg"])


def same(decoded: Any, sent: Any, path: str = "") -> None:
    """Each field Foxglove decoded equals the robot's (float32 fields to float32 precision, NaN as null)."""
    if isinstance(sent, dict) and set(sent) == {"secs", "nsecs"}:
        assert decoded == {"sec": sent["secs"], "nsec": sent["nsecs"]}, path
    elif isinstance(sent, dict):
        assert set(decoded) == set(sent), path
        for key in sent:
            same(decoded[key], sent[key], f"{path}.{key}")
    elif isinstance(sent, list):
        assert len(decoded) == len(sent), path
        for i, (d, s) in enumerate(zip(decoded, sent, strict=True)):
            same(d, s, f"{path}[{i}]")
    elif isinstance(sent, float) or isinstance(decoded, float) or decoded is None or sent is None:
        if sent is None or (isinstance(sent, float) and not math.isfinite(sent)):
            assert decoded is None, path
        else:
            assert decoded == pytest.approx(sent, rel=1e-6, abs=1e-6), path
    else:
        assert decoded == sent, path


def _stamp(msg: dict) -> tuple:
    stamp = msg["header"]["stamp"]
    return stamp.get("secs", stamp.get("sec")), stamp.get("nsecs", stamp.get("nsec", stamp.get("nanosec")))


def check(definitions: dict[str, tuple[str, str]], frames: dict[str, list[dict]],
          robot: dict[str, list[dict]], ros: int = 1) -> None:
    for topic, msgs in frames.items():
        assert msgs, f"no cbor-raw frame for {topic}"
        msg_type, text = definitions[topic]
        decoded = decode(ros, [{"type": msg_type, "definition": text,
                                "bytes_b64": base64.b64encode(m["bytes"]).decode()} for m in msgs])
        if "header" in robot[topic][0]:
            by_stamp = {_stamp(m): m for m in robot[topic]}
            matched = [(d, by_stamp[_stamp(d)]) for d in decoded if _stamp(d) in by_stamp]
            assert len(matched) >= len(decoded) // 2, f"{topic}: few messages matched the robot's"
            for d, sent in matched:
                same(d, sent, topic)
        else:
            values = [m["data"] for m in robot[topic]]
            for d in decoded:
                assert any(d["data"] == pytest.approx(v, rel=1e-6) for v in values), topic


def test_a_foxglove_like_client_gets_the_robots_own_bytes_through_the_front_door(stack):
    topics = [ODOM, BATTERY, SCAN]
    robot: dict[str, list[dict]] = {t: [] for t in topics}
    reference = threading.Thread(target=published, args=(f"ws://127.0.0.1:{stack.sim_port}", topics,
                                                          WINDOW_S + 4, robot))
    reference.start()
    time.sleep(1.0)
    definitions, frames = foxglove_session(ticket_url(stack, "vera"), topics, WINDOW_S)
    reference.join()
    check(definitions, frames, robot)
    # No throttle asked: the front door paces the robot's high-rate odometry (10 Hz by default).
    assert len(frames[ODOM]) <= 10 * WINDOW_S * 1.3 + 3


def test_the_simulator_serves_cbor_raw_like_the_real_server(stack):
    topics = [ODOM, SCAN]
    robot: dict[str, list[dict]] = {t: [] for t in topics}
    url = f"ws://127.0.0.1:{stack.sim_port}"
    reference = threading.Thread(target=published, args=(url, topics, WINDOW_S + 2, robot))
    reference.start()
    time.sleep(0.5)
    definitions, frames = foxglove_session(url, topics, WINDOW_S)
    reference.join()
    check(definitions, frames, robot)


def test_the_ros2_simulator_serves_cdr_with_ros2_definitions():
    topics = [ODOM, SCAN, ri.topic("amcl_pose", ri.ROS2).name]
    robot: dict[str, list[dict]] = {t: [] for t in topics}
    with SimThread(ros=2, startup_s=0.5) as sim:
        reference = threading.Thread(target=published, args=(sim.url, topics, WINDOW_S + 2, robot))
        reference.start()
        time.sleep(0.5)
        definitions, frames = foxglove_session(sim.url, topics, WINDOW_S, ros=2)
        reference.join()
    assert definitions[ODOM][0] == "nav_msgs/msg/Odometry"
    assert definitions[ODOM][1] == ROS2_ODOMETRY  # rosapi's layout, ROS 2's Header and Time
    check(definitions, frames, robot, ros=2)


ROS2_ODOMETRY = """std_msgs/Header header
string child_frame_id
geometry_msgs/PoseWithCovariance pose
geometry_msgs/TwistWithCovariance twist
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
================================================================================
MSG: geometry_msgs/PoseWithCovariance
geometry_msgs/Pose pose
float64[36] covariance
================================================================================
MSG: geometry_msgs/Pose
geometry_msgs/Point position
geometry_msgs/Quaternion orientation
================================================================================
MSG: geometry_msgs/Point
float64 x
float64 y
float64 z
================================================================================
MSG: geometry_msgs/Quaternion
float64 x
float64 y
float64 z
float64 w
================================================================================
MSG: geometry_msgs/TwistWithCovariance
geometry_msgs/Twist twist
float64[36] covariance
================================================================================
MSG: geometry_msgs/Twist
geometry_msgs/Vector3 linear
geometry_msgs/Vector3 angular
================================================================================
MSG: geometry_msgs/Vector3
float64 x
float64 y
float64 z
"""


def test_a_ros2_robots_messages_are_cdr_that_foxglove_reads():
    from robot.frontdoor.rawtypes import Serializer

    serializer = Serializer()
    serializer.learn(["/odom"], ["nav_msgs/msg/Odometry"], [ROS2_ODOMETRY])
    sent = {"header": {"stamp": {"sec": 1700000000, "nanosec": 5}, "frame_id": "odom"}, "child_frame_id": "base_link",
            "pose": {"pose": {"position": {"x": 1.5, "y": -2.0, "z": 0.0},
                              "orientation": {"x": 0.0, "y": 0.0, "z": 0.5, "w": 0.75}},
                     "covariance": [0.1 * i for i in range(36)]},
            "twist": {"twist": {"linear": {"x": 0.3, "y": 0.0, "z": 0.0}, "angular": {"x": 0.0, "y": 0.0, "z": None}},
                      "covariance": [0.0] * 36}}
    raw = serializer.serialize("nav_msgs/msg/Odometry", sent)
    [decoded] = decode(2, [{"type": "nav_msgs/msg/Odometry", "definition": ROS2_ODOMETRY,
                            "bytes_b64": base64.b64encode(raw).decode()}])
    assert decoded["header"]["stamp"] == {"sec": 1700000000, "nanosec": 5}
    assert decoded["header"]["frame_id"] == "odom" and decoded["child_frame_id"] == "base_link"
    assert decoded["pose"]["pose"]["position"] == {"x": 1.5, "y": -2.0, "z": 0.0}
    assert decoded["pose"]["covariance"] == pytest.approx([0.1 * i for i in range(36)])
    assert decoded["twist"]["twist"]["linear"]["x"] == 0.3 and decoded["twist"]["twist"]["angular"]["z"] is None
