"""``python manage.py simrobot``: run the robot simulator (rosbridge v2 + web_video_server look-alike)."""

from __future__ import annotations

import asyncio
import logging
import signal
from typing import Any

from django.core.management.base import BaseCommand, CommandParser

from robot.sim import SimRobot
from robot.sim.audio import MIC_CODINGS


class Command(BaseCommand):
    help = "Run the Cyborg simulator: a rosbridge v2 websocket server that behaves like the robot."

    def add_arguments(self, parser: CommandParser) -> None:
        parser.add_argument("--host", default="127.0.0.1")
        parser.add_argument("--port", type=int, default=9090, help="rosbridge websocket port (0: any free port)")
        parser.add_argument("--video-port", type=int, default=8080, help="web_video_server port (0: any)")
        parser.add_argument("--map", default="glassgarden", choices=["glassgarden", "large"])
        parser.add_argument("--seed", type=int, default=0)
        parser.add_argument("--pose-rate", type=float, default=10.0, help="/robot_pose and /odom rate, Hz")
        parser.add_argument("--startup-s", type=float, default=15.0, help="seconds in the startup state")
        parser.add_argument("--demo-s", type=float, default=30.0, help="seconds a demo lasts")
        parser.add_argument("--mic-coding", default="wave", choices=list(MIC_CODINGS),
                            help="what the microphone sends: raw PCM (wave) or mp3")
        parser.add_argument("--battery-soc", type=float, default=0.85, help="the battery's charge at start, 0-1")
        parser.add_argument("--time-scale", type=float, default=1.0,
                            help="the robot's world runs this many times as fast (motion, timers, pauses)")

    def handle(self, *args: Any, **opts: Any) -> None:
        logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)s %(name)s: %(message)s")
        logging.getLogger("websockets").setLevel(logging.WARNING)
        robot = SimRobot(
            host=str(opts["host"]), port=int(opts["port"]), video_port=int(opts["video_port"]),
            map_name=str(opts["map"]), seed=int(opts["seed"]),
            pose_rate_hz=float(opts["pose_rate"]), startup_s=float(opts["startup_s"]),
            demo_s=float(opts["demo_s"]), mic_coding=str(opts["mic_coding"]),
            time_scale=float(opts["time_scale"]), battery_soc=float(opts["battery_soc"]),
        )
        asyncio.run(self._serve(robot))

    async def _serve(self, robot: SimRobot) -> None:
        stop = asyncio.Event()
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGINT, signal.SIGTERM):
            loop.add_signal_handler(sig, stop.set)
        await robot.start()
        self.stdout.write(f"Simulator listening on {robot.url} (video on http://{robot.host}:{robot.video_port})")
        self.stdout.flush()
        await stop.wait()
        self.stdout.write("Simulator stopping")
        await robot.stop()
