"""``python -m robot.sim``: the simulator without Django (benches, scripts). Same flags as ``manage.py simrobot``."""

from __future__ import annotations

import argparse
import asyncio
import logging
import signal
from collections.abc import Callable

from .audio import MIC_CODINGS
from .robot import SimRobot


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(prog="python -m robot.sim", description=__doc__)
    p.add_argument("--host", default="127.0.0.1")
    p.add_argument("--port", type=int, default=9090)
    p.add_argument("--video-port", type=int, default=8080)
    p.add_argument("--map", default="glassgarden", choices=["glassgarden", "large"])
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--pose-rate", type=float, default=10.0)
    p.add_argument("--startup-s", type=float, default=15.0)
    p.add_argument("--demo-s", type=float, default=30.0)
    p.add_argument("--mic-coding", default="wave", choices=list(MIC_CODINGS))
    p.add_argument("--time-scale", type=float, default=1.0, help="the world runs this many times as fast")
    p.add_argument("--quiet", action="store_true", help="log warnings only")
    return p.parse_args(argv)


async def serve(robot: SimRobot, announce: Callable[[str], object] = print) -> None:
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, stop.set)
    await robot.start()
    announce(f"Simulator listening on {robot.url} (video on http://{robot.host}:{robot.video_port})")
    await stop.wait()
    await robot.stop()


def main(argv: list[str] | None = None) -> None:
    a = parse_args(argv)
    logging.basicConfig(level=logging.WARNING if a.quiet else logging.INFO,
                        format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    logging.getLogger("websockets").setLevel(logging.WARNING)
    robot = SimRobot(host=a.host, port=a.port, video_port=a.video_port, map_name=a.map, seed=a.seed,
                     pose_rate_hz=a.pose_rate, startup_s=a.startup_s, demo_s=a.demo_s,
                     mic_coding=a.mic_coding, time_scale=a.time_scale)
    asyncio.run(serve(robot, lambda line: print(line, flush=True)))


if __name__ == "__main__":
    main()
