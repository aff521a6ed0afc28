"""The simulator's command line (``python -m simulator``)."""

from __future__ import annotations

import argparse
import asyncio
import logging
import signal
from typing import Any

from .audio import MIC_CODINGS
from .robot import SimRobot


def add_arguments(p: argparse.ArgumentParser) -> None:
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
    p.add_argument("--quiet", action="store_true", help="log warnings only")


def run(opts: dict[str, Any]) -> None:
    """Serve a simulator built from the parsed flags until SIGINT or SIGTERM."""
    logging.basicConfig(level=logging.WARNING if opts["quiet"] else logging.INFO,
                        format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    logging.getLogger("websockets").setLevel(logging.WARNING)
    robot = SimRobot(
        host=opts["host"], port=opts["port"], video_port=opts["video_port"], map_name=opts["map"],
        seed=opts["seed"], pose_rate_hz=opts["pose_rate"], startup_s=opts["startup_s"], demo_s=opts["demo_s"],
        mic_coding=opts["mic_coding"], time_scale=opts["time_scale"], battery_soc=opts["battery_soc"],
    )
    asyncio.run(serve(robot))


async def serve(robot: SimRobot) -> None:
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, stop.set)
    await robot.start()
    print(f"Simulator listening on {robot.url} (video on http://{robot.host}:{robot.video_port})", flush=True)
    await stop.wait()
    print("Simulator stopping", flush=True)
    await robot.stop()
