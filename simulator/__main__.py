"""``python -m simulator``: run the Cyborg simulator (rosbridge v2 + web_video_server look-alike)."""

from __future__ import annotations

import argparse
import asyncio
import logging
import signal

from .nodes.audiovisual import MIC_CODINGS
from .robot import SimRobot


def parse_args() -> argparse.Namespace:
    p = argparse.ArgumentParser(prog="python -m simulator", description=__doc__)
    p.add_argument("--host", default="127.0.0.1")
    p.add_argument("--port", type=int, default=9090, help="rosbridge websocket port (0: any free port)")
    p.add_argument("--video-port", type=int, default=8080, help="web_video_server port (0: any)")
    p.add_argument("--map", default="glassgarden", choices=["glassgarden", "large"])
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--pose-rate", type=float, default=10.0, help="/robot_pose and /odom rate, Hz")
    p.add_argument("--startup-s", type=float, default=15.0, help="seconds in the startup state")
    p.add_argument("--demo-s", type=float, default=30.0, help="seconds a demo lasts")
    p.add_argument("--mic-coding", default="wave", choices=list(MIC_CODINGS),
                   help="what the microphone sends: raw PCM (wave) or mp3")
    p.add_argument("--battery-soc", type=float, default=0.85, help="the battery's charge at start, 0-1")
    p.add_argument("--time-scale", type=float, default=1.0,
                   help="the robot's world runs this many times as fast (motion, timers, pauses)")
    p.add_argument("--ros", type=int, default=1, choices=[1, 2],
                   help="which robot to be: ROS 1 (rosbridge 0.11, actionlib) or ROS 2 (Jazzy, rosbridge 2.x, Nav2)")
    p.add_argument("--goals-in-new-thread", action="store_true",
                   help="ROS 2: as rosbridge's send_action_goals_in_new_thread:=true (a goal no longer holds "
                        "its client's later frames, so cancel_action_goal works)")
    p.add_argument("--services-in-new-thread", action="store_true",
                   help="ROS 2: as rosbridge's call_services_in_new_thread:=true (an unanswered call no longer "
                        "wedges its client)")
    p.add_argument("--quiet", action="store_true", help="log warnings only")
    return p.parse_args()


def main() -> None:
    """Serve a simulator built from the flags until SIGINT or SIGTERM."""
    a = parse_args()
    logging.basicConfig(level=logging.WARNING if a.quiet else logging.INFO,
                        format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    logging.getLogger("websockets").setLevel(logging.WARNING)
    robot = SimRobot(
        host=a.host, port=a.port, video_port=a.video_port, map_name=a.map, seed=a.seed, pose_rate_hz=a.pose_rate,
        startup_s=a.startup_s, demo_s=a.demo_s, mic_coding=a.mic_coding, time_scale=a.time_scale,
        battery_soc=a.battery_soc, ros=a.ros, goals_in_new_thread=a.goals_in_new_thread,
        services_in_new_thread=a.services_in_new_thread,
    )
    asyncio.run(serve(robot))


async def serve(robot: SimRobot) -> None:
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        # A signal ignored on entry stays ignored: a script's background child (scripts/run.sh) leaves
        # a Ctrl-C to the script, which stops its children in order.
        if signal.getsignal(sig) is not signal.SIG_IGN:
            loop.add_signal_handler(sig, stop.set)
    await robot.start()
    print(f"Simulator listening on {robot.url} (video on http://{robot.host}:{robot.video_port})", flush=True)
    await stop.wait()
    print("Simulator stopping", flush=True)
    await robot.stop()


if __name__ == "__main__":
    main()
