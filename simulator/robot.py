"""SimRobot: the Cyborg's ROS nodes as one asyncio program behind a rosbridge v2 websocket.

It owns what the nodes share — the map, the base's body, the random source, the ROS graph
(``Broker``) and the clock — and composes one object per simulated node (``nodes/``):
RosAria, amcl + map_server + move_base + cyborg_navigation, the emotion system, the audio
and visual nodes, the controller (state machine, behaviours), the commander and rosbridge's
rosapi. The websocket server and web_video_server look-alike (camera.py) see it only
through the bus and camera.CameraHost. How to add a node: README.md.
"""

from __future__ import annotations

import asyncio
import logging
import random
import time
from typing import Any, TypeVar

from robot import interface as ri

from . import messages
from .bus import Bus, Clock, SimNode
from .camera import VideoServer
from .messages import DIALECTS
from .nodes.audiovisual import AudioVisualNode
from .nodes.base import BaseNode
from .nodes.bridge import BridgeNode
from .nodes.controller import CommanderNode, ControllerNode
from .nodes.costmaps import CostmapNode
from .nodes.diagnostics import DiagnosticsNode
from .nodes.emotion import EmotionNode
from .nodes.laser import Laser
from .nodes.localisation import LocalisationNode
from .nodes.navigation import NavigationNode
from .protocol import RosbridgeServer
from .world import Base, build

log = logging.getLogger("simulator")
N = TypeVar("N", bound=SimNode)


class SimRobot:
    def __init__(
        self,
        host: str = "127.0.0.1",
        port: int = 9090,
        video_port: int = 8080,
        map_name: str = "glassgarden",
        seed: int = 0,
        pose_rate_hz: float = 10.0,
        startup_s: float = 15.0,
        demo_s: float = 30.0,
        behaviour_s: float = 6.0,
        tts_s_per_char: float = 0.03,
        tts_min_s: float = 0.3,
        clip_s: float = 1.0,
        nav_speed: float = 0.6,
        commander_pause_s: float = ri.COMMANDER_PAUSE_S,
        battery_soc: float = 0.85,
        battery_drain_per_s: float = 0.0002,
        battery_charge_per_s: float = 0.002,
        tick_hz: float = 50.0,
        mic_tone_hz: float = 440.0,
        mic_coding: str = "wave",
        time_scale: float = 1.0,
        ros: int = ri.ROS1,
        goals_in_new_thread: bool = False,
        services_in_new_thread: bool = False,
    ) -> None:
        """``ros``: which rosbridge to be (1, or 2 for ROS 2 Jazzy with Nav2); the two ``*_in_new_thread``
        flags are the ROS 2 rosbridge's launch arguments of those names (off by default, as there)."""
        self.host = host
        self.port = port
        self.video_port = video_port
        self.tick_s = 1.0 / tick_hz
        self.rng = random.Random(seed)
        self.world = build(map_name, seed)
        x, y, yaw = self.world.start
        self.base = Base(self.world, x, y, yaw)  # the servers see base, world and bus
        self.clock = Clock(time_scale)
        self.ros = ros
        self.bus = Bus(self.clock, DIALECTS[ros], goals_in_new_thread, services_in_new_thread)
        for t in ri.topics(ros):
            self.bus.declare(t.name, t.type)

        self.nodes: list[SimNode] = []
        self._started = False
        # Added in tick order: physics, then navigation, emotions, state timers.
        self.base_node = self.add(BaseNode(self.base, self.world, self.rng, pose_rate_hz, battery_soc,
                                           battery_drain_per_s, battery_charge_per_s))
        self.nav_node = self.add(NavigationNode(self.base, self.world, self.rng, nav_speed, ros))
        self.add(LocalisationNode(self.base, self.rng))
        self.add(Laser(self.world, self.base))
        self.add(CostmapNode(self.base, self.world, lambda: self.nav_node.active))
        self.emotion_node = self.add(EmotionNode(self.rng))
        self.av_node = self.add(AudioVisualNode(tts_s_per_char, tts_min_s, clip_s, mic_tone_hz, mic_coding))
        self.controller = self.add(ControllerNode(self.rng, self.nav_node, self.av_node, self.emotion_node,
                                                  startup_s, demo_s, behaviour_s))
        self.base_node.battery_low = self.controller.battery_low
        self.commander = self.add(CommanderNode(commander_pause_s))
        self.add(DiagnosticsNode(self.base_node))
        self.bridge = self.add(BridgeNode(self.rng, lambda: self.nodes))
        self.server = RosbridgeServer(self.bus, self.bridge.publish_client_count)  # both listen from start()
        self.video = VideoServer(self)

    # --- lifecycle -------------------------------------------------------------------

    def add(self, node: N) -> N:
        """Make ``node`` part of the robot: started with the others, listed by /rosapi/nodes."""
        if self._started:
            raise RuntimeError("add nodes before start()")
        self.nodes.append(node)
        return node

    @property
    def url(self) -> str:
        return f"ws://{self.host}:{self.port}"

    async def start(self) -> None:
        self._started = True
        for node in self.nodes:
            node.start(self.bus)
        # Encode the latched map now: a 4000 x 4000 map takes seconds, better before than mid-session.
        self.bus.latched_frame(self.bus.topic("map").name)
        await self.server.start(self.host, self.port)
        self.port = self.server.port
        await self.video.start(self.host, self.video_port)
        self.video_port = self.video.port
        self.bus.spawn(self._tick_loop())
        self.bus.rosout(2, "/rosbridge_websocket", f"Rosbridge WebSocket server started at {self.url}")
        log.info("Simulator listening on %s (video on http://%s:%d)", self.url, self.host, self.video_port)

    async def stop(self) -> None:
        tasks = self.bus.tasks
        for t in tasks:
            t.cancel()
        for node in self.nodes:
            node.stop()
        await self.video.stop()
        await self.server.stop()
        await asyncio.gather(*tasks, return_exceptions=True)
        tasks.clear()

    async def _tick_loop(self) -> None:
        last = self.clock.now()
        next_t = time.monotonic()
        while True:
            next_t += self.tick_s
            delay = next_t - time.monotonic()
            if delay < -1.0:  # fell far behind (host paused): do not try to catch up
                next_t = time.monotonic()
            await asyncio.sleep(max(0.0, delay))
            now = self.clock.now()
            dt, last = min(now - last, 0.2 * self.clock.scale), now
            try:
                self.clock.tick(now, dt, time.monotonic())
            except Exception:
                log.exception("simulator tick failed")

    # --- what the servers see (camera.CameraHost) -----------------------------------------

    def plan(self) -> list[tuple[float, float]]:
        return self.nav_node.remaining()

    def caption(self) -> str:
        return f"state={self.controller.sm.state} emotion={self.emotion_node.name}"

    def publish_external(self, topic: str, msg: dict[str, Any], count: int = 1) -> int:
        """Publish ``msg`` to the topic's subscribers as if a robot node sent it (benches inject bursts)."""
        msg_type = self.bus.types.get(topic)
        if msg_type is not None and messages.known(msg_type):
            msg = messages.normalize(msg_type, msg)
        for _ in range(count):
            self.bus.publish_name(topic, msg)
        return count

    # --- introspection (tests, benches, /sim/introspect) --------------------------------

    def subscription_count(self, topic_name: str) -> int:
        return self.bus.subscription_count(topic_name)

    def received(self, topic_name: str) -> list[dict[str, Any]]:
        return [r.msg for r in self.bus.received_msgs.get(topic_name, ())]

    def received_with_times(self, topic_name: str, last: int | None = None) -> list[dict[str, Any]]:
        items = list(self.bus.received_msgs.get(topic_name, ()))
        if last is not None:
            items = items[-last:] if last > 0 else []
        return [{"t": r.t, "msg": r.msg} for r in items]

    def received_count(self, topic_name: str) -> int:
        return self.bus.received_counts[topic_name]

    def snapshot(self) -> dict[str, Any]:
        b, w, bus, nav, av, base = self.base, self.world, self.bus, self.nav_node, self.av_node, self.base_node
        goal = nav.move_base.current
        return {
            "subscriptions": {t: bus.subscription_count(t) for t in sorted(bus.subs)},
            "received_counts": dict(bus.received_counts),
            "clients": len(bus.clients),
            "url": self.url,
            "video_port": self.video_port,
            "video_streams": self.video.streams,
            "map": {"name": w.name, "width": w.width, "height": w.height,
                    "resolution": w.resolution, "origin": [w.origin_x, w.origin_y]},
            "state": {
                "pose": {"x": b.x, "y": b.y, "yaw": b.yaw}, "v": b.v, "w": b.w, "motors": b.motors,
                "bumped": b.bumped, "battery": {"soc": base.soc, "voltage": base.voltage(),
                                                "recharge_state": base.recharge_state},
                "smach_state": self.controller.sm.state, "smach_top": self.controller.sm.top,
                "emotion": {"name": self.emotion_node.name, "pad": list(self.emotion_node.pad)},
                "emotion_system": self.emotion_node.enabled, "mode": self.commander.mode, "dome": av.dome_mode,
                "tts_queue": av.pending(), "tts_spoken": av.done_count,
                "playing": av.playing, "current_location": nav.current_location,
                "goal": None if goal is None else {"id": goal.id, "status": goal.status},
                "navigating": nav.active,
            },
        }
