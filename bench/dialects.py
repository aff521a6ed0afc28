"""The product on a ROS 1 and on a ROS 2 robot, one run each: does the dialect layer cost anything?

For each ROS the stack (Daphne, embedded default) runs against ``python -m simulator --ros N``:
- update: /odom's header stamp (the simulator's wall clock at publish) to a /ws/live/ frame;
- command: a speech command over the API to the simulator receiving it (bench/api_throughput.py's);
and on ROS 2, with unmodified roslibpy as another tool sending Nav2 goals on its own socket:
- goal to feedback: send_action_goal to the first action_feedback;
- E-STOP to goal canceled: the E-STOP API call to that tool's action_result with CANCELED (the link
  cancels every goal through /navigate_to_pose/_action/cancel_goal).
No arguments. Prints ``name: value`` lines.
"""

from __future__ import annotations

import asyncio
import json
import logging
import sys
import threading
import time
import urllib.error
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

import roslibpy  # noqa: E402
from _stats import quantile  # noqa: E402
from api_throughput import UNTHROTTLED, speech_commands  # noqa: E402
from commands import call  # noqa: E402
from websockets.asyncio.client import connect  # noqa: E402

from robot import interface as ri  # noqa: E402
from tests.stack import PASSWORD, Stack  # noqa: E402

log = logging.getLogger("bench.dialects")
UPDATE_S = 10.0
GOALS = 20
GOAL = {"pose": {"header": {"frame_id": "map"}, "pose": {"position": {"x": 6.5, "y": -1.0, "z": 0.0},
                                                         "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}},
        "behavior_tree": ""}


async def update_latencies(stack: Stack) -> list[float]:
    cookie = stack.login_cookie("otto")
    out: list[float] = []
    async with connect(f"ws://127.0.0.1:{stack.web_port}/ws/live/", origin=stack.url,
                       additional_headers={"Cookie": cookie}, max_size=None) as ws:
        await ws.send(json.dumps({"action": "watch", "keys": ["odom"]}))
        end = time.time() + UPDATE_S
        while time.time() < end:
            raw = await asyncio.wait_for(ws.recv(), 10)
            now = time.time()
            frame = json.loads(raw)
            for update in frame.get("updates") or ([frame] if frame.get("kind") == "update" else []):
                if update.get("key") == "odom":
                    stamp = update["msg"]["header"]["stamp"]
                    out.append((now - stamp["secs"] - stamp["nsecs"] / 1e9) * 1000)
    return sorted(out[5:])  # the first frames are the snapshot replay


def nav2_goals(stack: Stack, token: str) -> tuple[list[float], list[float]]:
    """(goal to first feedback, E-STOP to CANCELED), in ms, over ``GOALS`` goals."""
    ros = roslibpy.Ros("127.0.0.1", stack.sim_port)
    ros.run(timeout=10)
    nav = ri.action("move_base", ri.ROS2)
    client = roslibpy.ActionClient(ros, nav.name, nav.type)
    to_feedback, to_canceled = [], []
    try:
        for _ in range(GOALS):
            got_feedback, got_result = threading.Event(), threading.Event()
            at: dict[str, float] = {}

            def feedback(_: object, at: dict[str, float] = at, ev: threading.Event = got_feedback) -> None:
                at.setdefault("feedback", time.perf_counter())
                ev.set()

            def result(r: dict, at: dict[str, float] = at, ev: threading.Event = got_result) -> None:
                at["result"], at["status"] = time.perf_counter(), r.get("status")
                ev.set()

            t0 = time.perf_counter()
            client.send_goal(roslibpy.Goal(GOAL), result, feedback, result)
            if not got_feedback.wait(10):
                raise SystemExit("no feedback for a Nav2 goal")
            to_feedback.append((at["feedback"] - t0) * 1000)
            t1 = time.perf_counter()
            try:
                call(f"{stack.url}/api/robot/estop/", {}, token)
            except urllib.error.HTTPError as exc:  # 502: a step other than the cancel failed; the goal is what counts
                log.warning("E-STOP answered %s", exc.code)
            if not got_result.wait(10):
                raise SystemExit("the E-STOP did not end the Nav2 goal")
            if at["status"] != roslibpy.core.GoalStatus.CANCELED:
                raise SystemExit(f"the goal ended {at['status']}, not CANCELED")
            to_canceled.append((at["result"] - t1) * 1000)
            call(f"{stack.url}/api/robot/estop/release/", {"confirm": True}, token)
            time.sleep(0.2)
    finally:
        ros.close()
    return sorted(to_feedback), sorted(to_canceled)


def run(ros: int) -> dict[str, list[float]]:
    with Stack(sim_args=("--startup-s", "0.5", "--ros", str(ros)), env=UNTHROTTLED) as stack:
        stack.wait_robot_online()
        time.sleep(2.0)  # the link finds out the ROS and subscribes by its names
        token = call(f"{stack.url}/api/auth/token/", {"username": "otto", "password": PASSWORD})["token"]
        try:
            found = {"update": asyncio.run(update_latencies(stack)), "command": speech_commands(stack, token)[0]}
            if ros == ri.ROS2:
                found["goal_to_feedback"], found["estop_to_goal_canceled"] = nav2_goals(stack, token)
        except Exception:
            log.error("ROS %d: the server's log ends\n%s\nthe simulator's\n%s", ros, stack.log("web")[-3000:],
                      stack.log("sim")[-2000:])
            raise
        return found


def main() -> None:
    logging.basicConfig(stream=sys.stderr, level=logging.INFO, format="%(message)s")
    results = {ros: run(ros) for ros in ri.ROS_VERSIONS}
    p99 = {ros: {name: quantile(values, 0.99) for name, values in found.items()} for ros, found in results.items()}
    for ros in ri.ROS_VERSIONS:
        print(f"ros{ros}_update_p99_ms: {p99[ros]['update']:.1f}")
        print(f"ros{ros}_command_p99_ms: {p99[ros]['command']:.1f}")
    print(f"ros2_to_ros1_update_p99_ratio: {p99[2]['update'] / p99[1]['update']:.2f}")
    print(f"ros2_to_ros1_command_p99_ratio: {p99[2]['command'] / p99[1]['command']:.2f}")
    print(f"ros2_goal_to_feedback_p99_ms: {p99[2]['goal_to_feedback']:.1f}")
    print(f"ros2_estop_to_goal_canceled_p99_ms: {p99[2]['estop_to_goal_canceled']:.1f}")


if __name__ == "__main__":
    main()
