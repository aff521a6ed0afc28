"""SimRobot: the Cyborg's ROS nodes as one asyncio program behind a rosbridge v2 websocket.

It plays RosAria (base, battery, motors, bumpers, sonar), amcl + map_server, move_base,
the cyborg_controller (state machine, emotion system), the commander, the audio and
visual nodes, cyborg_navigation, rosbridge's rosapi, and web_video_server (camera.py).
"""

from __future__ import annotations

import asyncio
import collections
import json
import logging
import math
import random
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from robot import interface as ri

from . import messages, world
from .actions import ABORTED, PREEMPTED, SUCCEEDED, ActionServer, Goal
from .audio import Audio, Microphone, Speaker
from .emotions import EmotionSystem
from .navigation import Navigator
from .protocol import Broker, ServiceError
from .statemachine import NAVIGATION_LEAVES, StateMachine

log = logging.getLogger("robot.sim")

NODES = (
    "/RosAria", "/amcl", "/map_server", "/move_base", "/robot_pose_publisher", "/cyborg_controller",
    "/cyborg_commander", "/cyborg_audio", "/cyborg_visual", "/cyborg_navigation", "/cyborg_behavior",
    "/cyborg_eventscheduler", "/rosapi", "/rosbridge_websocket", "/web_video_server", "/rosout",
)
VIDEO_TOPIC = "/videostream"
CHATTER = (
    ("/amcl", "Laser scan received, updating particle filter"),
    ("/move_base", "Got new plan" ),
    ("/cyborg_eventscheduler", "No scheduled events right now"),
    ("/RosAria", "Battery check ok"),
    ("/cyborg_controller", "Motivator tick"),
)
BEHAVIOUR_PRESETS: dict[str, dict[str, Any]] = {
    # state: visual mode, utterance, clip, emotional feedback (dp, da, dd)
    "show_off_mea": {"visual": "mea", "say": "Look at my brain! It is made of living neurons.", "pad": (0.1, 0.1, 0.1)},
    "conveying_emotional_state": {"visual": "emotion", "say": "Let me tell you how I feel.", "pad": (0.05, 0, 0)},
    "music_horror": {"visual": "horror", "clip": "horror_music", "pad": (-0.05, 0.2, 0)},
    "astrolanguage": {"visual": "astro", "clip": "astrolanguage", "pad": (0.05, 0.05, 0)},
    "waking_up": {"visual": "wake", "say": "Good morning, everyone!", "pad": (0.1, 0.2, 0)},
    "sleepy": {"visual": "sleepy", "say": "I am getting sleepy.", "pad": (0, -0.2, 0)},
    "exhausted": {"visual": "exhausted", "say": "My battery is low, going to the charging station."},
    "sleeping": {"visual": "sleeping"},
    "demo": {"visual": "demo", "say": "Hello! I am the NTNU Cyborg. This is a demonstration."},
}


@dataclass
class Schedule:
    period: float
    fn: Callable[[], None]
    due: float = 0.0


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
    ) -> None:
        self.host = host
        self.port = port
        self.video_port = video_port
        self.seed = seed
        self.pose_rate_hz = pose_rate_hz
        self.startup_s = startup_s
        self.demo_s = demo_s
        self.behaviour_s = behaviour_s
        self.commander_pause_s = commander_pause_s
        self.tick_s = 1.0 / tick_hz
        self.rng = random.Random(seed)
        self.world = world.build(map_name, seed)
        self.planner = world.Planner(self.world)
        x, y, yaw = self.world.start
        self.base = world.Base(self.world, x, y, yaw)
        self.navigator = Navigator(self.base, max_v=nav_speed)
        self.soc = battery_soc
        self.drain = battery_drain_per_s
        self.charge = battery_charge_per_s
        self.recharge_state = 0
        self.dome_mode = "default"
        self.current_location = ""
        self.bumper_until = 0.0
        self.rosout_log: collections.deque[dict[str, Any]] = collections.deque(maxlen=200)
        self._warned: dict[str, float] = {}
        self._state_deadline: float | None = None
        self._nav_done: Callable[[int], None] | None = None
        self._internal_nav_goal: Goal | None = None
        self._low_battery_fired = False
        self._mode_queue: asyncio.Queue[str] | None = None
        self._tasks: list[asyncio.Task[Any]] = []
        self._started = False
        self._map_load_time = messages.stamp()
        self.mode = ""  # last robot_mode the commander ran
        self.params: dict[str, Any] = {"/rosdistro": "noetic", "/use_sim_time": False,
                                       "/robot_description": "Pioneer LX (simulated)"}

        self.broker = Broker(self._bridge_log)
        self.sm = StateMachine(self._on_state_change)
        self.emotions = EmotionSystem(self.rng, self._on_emotion)
        self.audio = Audio(self._on_spoken, self._on_played, tts_s_per_char, tts_min_s, clip_s)
        self.mic = Microphone(lambda m: self._publish("audio", m), lambda: self._wants("audio"), freq_hz=mic_tone_hz)
        self.speaker = Speaker()
        mb, nav = ri.action("move_base"), ri.action("navigation")
        self.move_base = ActionServer(mb.name, mb.type, self._publish_name, self._move_base_goal,
                                      self._move_base_cancel)
        self.navigation = ActionServer(nav.name, nav.type, self._publish_name, self._navigation_goal,
                                       self._navigation_cancel)
        self._declare()
        self._schedules = self._make_schedules()
        self.server: Any = None
        self.video: Any = None

    # --- wiring ----------------------------------------------------------------------

    def _declare(self) -> None:
        b = self.broker
        for t in ri.topics():
            b.declare(t.name, t.type)
        for server in (self.move_base, self.navigation):
            for name, msg_type in server.topics.items():
                b.declare(name, msg_type)
        b.declare("/connected_clients", "rosbridge_msgs/ConnectedClients")
        on: dict[str, Callable[[dict[str, Any]], object]] = {
            "cmd_vel": self._cmd_vel, "initialpose": self._initialpose,
            "move_base_simple_goal": self._simple_goal, "register_event": self._register_event,
            "emotional_controller": self._emotional_controller, "set_emotional_state": self._set_emotion,
            "emotional_feedback": self._emotional_feedback, "text_to_speech": lambda m: self.audio.say(m["data"]),
            "playback": self._playback, "domecontrol": self._domecontrol, "robot_mode": self._robot_mode,
            "speaker": self.speaker.on_data, "speaker_info": self.speaker.on_info,
        }
        for key, handler in on.items():
            b.on_publish(ri.topic(key).name, handler)
        b.on_publish(f"{self.move_base.name}/goal", self.move_base.receive_goal)
        b.on_publish(f"{self.move_base.name}/cancel", self.move_base.receive_cancel)
        b.on_publish(f"{self.navigation.name}/goal", self.navigation.receive_goal)
        b.on_publish(f"{self.navigation.name}/cancel", self.navigation.receive_cancel)
        svc: dict[str, Callable[[dict[str, Any]], dict[str, Any]]] = {
            "enable_motors": lambda r: self._set_motors(True), "disable_motors": lambda r: self._set_motors(False),
            "get_emotional_state": self._get_emotional_state,
            "rosapi_topics": lambda r: self._rosapi_topics(),
            "rosapi_topic_type": lambda r: {"type": self.broker.types.get(r["topic"], "")},
            "rosapi_services": lambda r: {"services": sorted(self.broker.services)},
            "rosapi_nodes": lambda r: {"nodes": list(NODES)},
            "rosapi_get_time": lambda r: {"time": messages.stamp()},
        }
        for key, handler in svc.items():
            s = ri.service(key)
            b.service(s.name, s.type, handler)
        extra: dict[str, tuple[str, Callable[[dict[str, Any]], dict[str, Any]]]] = {
            "/rosapi/topics_for_type": ("rosapi/TopicsForType", lambda r: {
                "topics": sorted(t for t, ty in self.broker.types.items() if ty == r["type"])}),
            "/rosapi/service_type": ("rosapi/ServiceType", lambda r: {
                "type": self.broker.services.get(r["service"], ("",))[0]}),
            "/rosapi/get_param": ("rosapi/GetParam", self._get_param),
            "/rosapi/has_param": ("rosapi/HasParam", lambda r: {"exists": r["name"] in self.params}),
            "/rosapi/get_param_names": ("rosapi/GetParamNames", lambda r: {"names": sorted(self.params)}),
            "/rosapi/message_details": ("rosapi/MessageDetails", self._message_details),
        }
        for name, (srv_type, handler) in extra.items():
            b.service(name, srv_type, handler)
        b.publish_lazily_latched(ri.topic("map").name, self._map_message)

    def _make_schedules(self) -> list[Schedule]:
        S = Schedule
        return [
            S(1.0 / self.pose_rate_hz, self._pub_pose),
            S(1.0 / 25.0, self._pub_tf),
            S(0.5, self._pub_amcl),
            S(1.0, self._pub_particles),
            S(0.2, self._pub_sonar),
            S(0.5, self._pub_bumper),
            S(1.0, self._pub_battery),
            S(1.0, self._pub_motors),
            S(0.2, self._pub_action_status),
            S(1.0, self._pub_plan),
            S(0.2, self._nav_feedback),
            S(5.0, self._pub_transitions),
            S(0.5, self._pub_smach_status),
            S(5.0, self._pub_smach_structure),
            S(1.0, self._pub_emotion),
            S(1.0, self._pub_location),
            S(5.0, self._pub_global_costmap),
            S(1.0, self._pub_local_costmap),
            S(8.0, self._chatter),
        ]

    # --- lifecycle -------------------------------------------------------------------

    @property
    def url(self) -> str:
        return f"ws://{self.host}:{self.port}"

    async def start(self) -> None:
        from .camera import VideoServer
        from .server import RosbridgeServer

        # Encode the latched map now: a 4000 x 4000 map takes seconds, better before than mid-session.
        self.broker.latched_frame(ri.topic("map").name)
        self.server = RosbridgeServer(self)
        await self.server.start(self.host, self.port)
        self.port = self.server.port
        self.video = VideoServer(self)
        await self.video.start(self.host, self.video_port)
        self.video_port = self.video.port
        loop = asyncio.get_running_loop()
        self._mode_queue = asyncio.Queue()
        self.audio.start()
        self.mic.start()
        self._publish("audio_info", self.mic.info())
        self._tasks += [loop.create_task(self._tick_loop()), loop.create_task(self._commander_loop())]
        self._started = True
        self._publish_client_count()
        self._publish("tf_static", {"transforms": [
            self._transform("base_link", "laser", 0.2, 0.0, 0.0),
            self._transform("base_link", "sonar", 0.1, 0.0, 0.0),
        ]})
        self._on_state_change("", "", self.sm.state)
        self.rosout(2, "/rosbridge_websocket", f"Rosbridge WebSocket server started at {self.url}")
        log.info("Simulator listening on %s (video on http://%s:%d)", self.url, self.host, self.video_port)

    async def stop(self) -> None:
        for t in self._tasks:
            t.cancel()
        self.audio.stop()
        self.mic.stop()
        if self.video is not None:
            await self.video.stop()
        if self.server is not None:
            await self.server.stop()
        await asyncio.gather(*self._tasks, return_exceptions=True)
        self._tasks.clear()

    # --- introspection ---------------------------------------------------------------

    def subscription_count(self, topic_name: str) -> int:
        return self.broker.subscription_count(topic_name)

    def received(self, topic_name: str) -> list[dict[str, Any]]:
        return [r.msg for r in self.broker.received(topic_name)]

    def received_with_times(self, topic_name: str, last: int | None = None) -> list[dict[str, Any]]:
        items = self.broker.received(topic_name)
        if last is not None:
            items = items[-last:] if last > 0 else []
        return [{"t": r.t, "msg": r.msg} for r in items]

    def received_count(self, topic_name: str) -> int:
        return self.broker.received_counts[topic_name]

    def snapshot(self) -> dict[str, Any]:
        b = self.base
        goal = self.move_base.current
        return {
            "subscriptions": {t: self.broker.subscription_count(t) for t in sorted(self.broker.subs)},
            "received_counts": dict(self.broker.received_counts),
            "clients": len(self.broker.clients),
            "url": self.url,
            "video_port": self.video_port,
            "video_streams": self.video.streams if self.video is not None else 0,
            "map": {"name": self.world.name, "width": self.world.width, "height": self.world.height,
                    "resolution": self.world.resolution, "origin": [self.world.origin_x, self.world.origin_y]},
            "state": {
                "pose": {"x": b.x, "y": b.y, "yaw": b.yaw}, "v": b.v, "w": b.w, "motors": b.motors,
                "bumped": b.bumped, "battery": {"soc": self.soc, "voltage": self.voltage(),
                                                "recharge_state": self.recharge_state},
                "smach_state": self.sm.state, "smach_top": self.sm.top,
                "emotion": {"name": self.emotions.name, "pad": list(self.emotions.pad)},
                "emotion_system": self.emotions.enabled, "mode": self.mode, "dome": self.dome_mode,
                "tts_queue": self.audio.pending(), "tts_spoken": self.audio.done_count,
                "playing": self.audio.playing, "current_location": self.current_location,
                "goal": None if goal is None else {"id": goal.id, "status": goal.status},
                "navigating": self.navigator.active,
            },
        }

    # --- publishing helpers ----------------------------------------------------------

    def _publish(self, key: str, msg: dict[str, Any]) -> None:
        t = ri.topic(key)
        self.broker.publish(t.name, msg, latch=t.latched)

    def _publish_name(self, name: str, msg: dict[str, Any]) -> None:
        self.broker.publish(name, msg)

    def _wants(self, key: str) -> bool:
        return self.broker.wants(ri.topic(key).name)

    def publish_external(self, topic: str, msg: dict[str, Any], count: int = 1) -> int:
        """Publish ``msg`` to the topic's subscribers as if a robot node sent it (benches inject bursts)."""
        msg_type = self.broker.types.get(topic)
        if msg_type is not None and messages.known(msg_type):
            msg = messages.normalize(msg_type, msg)
        for _ in range(count):
            self.broker.publish(topic, msg)
        return count

    def _internal(self, key: str, msg: dict[str, Any]) -> None:
        """A robot node publishing on a topic other nodes listen to (the commander's events)."""
        name = ri.topic(key).name
        self.broker.publish(name, msg)
        for handler in self.broker.handlers.get(name, ()):
            handler(msg)

    def rosout(self, level: int, node: str, text: str) -> None:
        msg = {"header": messages.header(), "level": level, "name": node, "msg": text, "file": "sim.py",
               "function": "", "line": 0, "topics": ["/rosout"]}
        self.rosout_log.append(msg)
        log.log({1: 10, 2: 20, 4: 30, 8: 40, 16: 50}.get(level, 20), "%s: %s", node, text)
        self._publish("rosout", msg)

    def _warn_once(self, key: str, node: str, text: str, every_s: float = 2.0, level: int = 4) -> None:
        now = time.monotonic()
        if now - self._warned.get(key, -math.inf) >= every_s:
            self._warned[key] = now
            self.rosout(level, node, text)

    def _bridge_log(self, level: int, text: str) -> None:
        self.rosout(level, "/rosbridge_websocket", text)

    def client_connected(self) -> None:
        self._publish_client_count()

    def _publish_client_count(self) -> None:
        self._publish("client_count", {"data": len(self.broker.clients)})
        self.broker.publish("/connected_clients", {"clients": [
            {"ip_address": c.address, "connection_time": messages.stamp(c.connected_at)}
            for c in self.broker.clients.values()]}, latch=True)

    # --- command handlers ------------------------------------------------------------

    def _cmd_vel(self, m: dict[str, Any]) -> None:
        if not self.base.motors:
            self._warn_once("motors_off", "/RosAria", "Motors are disabled: ignoring cmd_vel", 5.0)
            return
        self.base.command(m["linear"]["x"], m["angular"]["z"], time.monotonic())

    def _initialpose(self, m: dict[str, Any]) -> None:
        p = m["pose"]["pose"]
        yaw = world.quaternion_to_yaw(p["orientation"])
        self.base.teleport(p["position"]["x"], p["position"]["y"], yaw)
        self.rosout(2, "/amcl", f"Setting pose ({time.time():.6f}): {p['position']['x']:.3f} "
                                f"{p['position']['y']:.3f} {yaw:.3f}")
        goal = self.move_base.current
        if goal is not None and self.navigator.active:
            self._move_base_goal(goal)  # replan from the new pose

    def _simple_goal(self, m: dict[str, Any]) -> None:
        self.move_base.receive_goal({"goal_id": {"stamp": {"secs": 0, "nsecs": 0}, "id": ""},
                                     "goal": {"target_pose": m}})

    def _register_event(self, m: dict[str, Any]) -> None:
        self.fire(m["data"])

    def fire(self, event: str) -> bool:
        before = self.sm.state
        if not self.sm.fire(event):
            self.rosout(4, "/cyborg_controller", f"Event '{event}' is not a transition of state '{before}': ignored")
            return False
        return True

    def _emotional_controller(self, m: dict[str, Any]) -> None:
        value = m["data"]
        if value.upper() not in (ri.EMOTION_SYSTEM_ON, ri.EMOTION_SYSTEM_OFF):
            self.rosout(4, "/cyborg_controller", f"Emotion system switch '{value}' not understood (ON/OFF)")
            return
        self.emotions.enabled = value.upper() == ri.EMOTION_SYSTEM_ON
        self.rosout(2, "/cyborg_controller", f"Emotion system {'on' if self.emotions.enabled else 'off'}")
        self._publish("emotion_system_status", {"data": self.emotions.enabled})

    def _set_emotion(self, m: dict[str, Any]) -> None:
        if not self.emotions.set(m["data"]):
            self.rosout(4, "/cyborg_controller", f"Unknown emotional state '{m['data']}': ignored")

    def _emotional_feedback(self, m: dict[str, Any]) -> None:
        self.emotions.feedback(m["delta_pleasure"], m["delta_arousal"], m["delta_dominance"])

    def _playback(self, m: dict[str, Any]) -> None:
        self.rosout(2, "/cyborg_audio", f"Playing sound clip {m['data']}")
        self.audio.play(m["data"])

    def _domecontrol(self, m: dict[str, Any]) -> None:
        self.dome_mode = m["data"]
        self.rosout(2, "/cyborg_visual", f"Dome visual mode set to {m['data']}")

    def _robot_mode(self, m: dict[str, Any]) -> None:
        assert self._mode_queue is not None
        self._mode_queue.put_nowait(m["data"])

    def _set_motors(self, on: bool) -> dict[str, Any]:
        self.base.motors = on
        if not on:
            self.base.command(0.0, 0.0, time.monotonic())
        self.rosout(2, "/RosAria", f"Motors {'enabled' if on else 'disabled'}")
        self._publish("motors_state", {"data": on})
        return {}

    def _get_emotional_state(self, r: dict[str, Any]) -> dict[str, Any]:
        p, a, d = self.emotions.pad
        return {"emotional_state": self.emotions.name, "current_pleasure": p, "current_arousal": a,
                "current_dominance": d}

    def _rosapi_topics(self) -> dict[str, Any]:
        names = sorted(self.broker.types)
        return {"topics": names, "types": [self.broker.types[n] for n in names]}

    def _get_param(self, r: dict[str, Any]) -> dict[str, Any]:
        if r["name"] in self.params:
            return {"value": json.dumps(self.params[r["name"]])}
        return {"value": r["default"]}

    def _message_details(self, r: dict[str, Any]) -> dict[str, Any]:
        if not messages.known(r["type"]):
            raise ServiceError(f"Unable to load the manifest for message type {r['type']}")
        return {"typedefs": messages.typedefs(r["type"])}

    # --- commander -------------------------------------------------------------------

    async def _commander_loop(self) -> None:
        assert self._mode_queue is not None
        while True:
            name = await self._mode_queue.get()
            try:
                mode = ri.Mode(name)
            except ValueError:
                self.rosout(4, "/cyborg_commander", f"Unknown robot mode '{name}'")
                continue
            self.mode = mode.value
            self.rosout(2, "/cyborg_commander", f"Robot mode: {mode.value}")
            for kind, value in ri.COMMANDER_SEQUENCES[mode]:
                if kind == "pause":
                    await asyncio.sleep(self.commander_pause_s)  # every pause in the sequences is this one
                elif kind == "event":
                    self._internal("register_event", {"data": str(value)})
                elif kind == "emotion_system":
                    on = ri.EMOTION_SYSTEM_ON if value else ri.EMOTION_SYSTEM_OFF
                    self._internal("emotional_controller", {"data": on})

    # --- state machine -----------------------------------------------------------------

    def _on_state_change(self, event: str, old: str, new: str) -> None:
        now = time.monotonic()
        self._state_deadline = None
        if event:
            self.rosout(2, "/cyborg_controller", f"State transition: {old} --[{event}]--> {new}")
        self._publish("state_change", {"event": event, "from_system_state": old, "to_system_state": new})
        self._pub_transitions()
        self._pub_smach_status()
        leaving_nav = (old in NAVIGATION_LEAVES or old == "exhausted") and new not in NAVIGATION_LEAVES
        if leaving_nav and self._internal_nav_goal is not None:
            goal, self._internal_nav_goal = self._internal_nav_goal, None
            self._nav_done = None
            self.move_base.receive_cancel({"id": goal.id, "stamp": {"secs": 0, "nsecs": 0}})
        preset = BEHAVIOUR_PRESETS.get(new)
        if preset and old != new:
            if "visual" in preset:
                self.dome_mode = preset["visual"]
            if "say" in preset:
                self.audio.say(preset["say"])
            if "clip" in preset:
                self.audio.play(preset["clip"])
            if "pad" in preset:
                self.emotions.feedback(*preset["pad"])
        if new == "startup":
            self._state_deadline = now + self.startup_s
        elif new == "demo":
            self._state_deadline = now + self.demo_s
        elif new in ("show_off_mea", "conveying_emotional_state", "music_horror", "astrolanguage", "waking_up",
                     "sleepy"):
            self._state_deadline = now + self.behaviour_s
        elif new == "navigation_planning":
            self._state_deadline = now + 0.3
        elif new in ("navigation_go_to_emotional", "navigation_go_to_schedular", "wandering_emotional"):
            self._behaviour_navigate(new)
        elif new == "exhausted":
            self._behaviour_navigate(new, "charging_station")

    def _state_timer(self) -> None:
        state = self.sm.state
        if state == "navigation_planning":
            if self.sm.entered_by == "navigation_schedular":
                self.fire("navigation_go_to_schedular")
            else:
                self.fire("navigation_go_to_emotional" if self.rng.random() < 0.5 else "wandering_emotional")
        else:
            self.fire("succeeded")

    def _behaviour_navigate(self, state: str, location: str | None = None) -> None:
        if location is None:
            names = sorted(n for n in self.world.locations if n != "charging_station")
            location = self.rng.choice(names)
        loc = self.world.locations[location]
        if state == "wandering_emotional":
            x, y = self._random_free_point()
            target = (x, y, self.rng.uniform(-math.pi, math.pi))
        else:
            target = (loc.x, loc.y, loc.yaw)
        where = "somewhere" if state == "wandering_emotional" else location
        self.rosout(2, "/cyborg_navigation", f"{state}: heading to {where}")

        def done(status: int) -> None:
            self._internal_nav_goal = None
            if self.sm.state == state:
                self.fire("succeeded" if status == SUCCEEDED else "aborted")

        self._internal_nav_goal = self.navigate(*target, done)

    def _random_free_point(self) -> tuple[float, float]:
        w = self.world
        for _ in range(200):
            x = w.origin_x + self.rng.uniform(0, w.width * w.resolution)
            y = w.origin_y + self.rng.uniform(0, w.height * w.resolution)
            r, c = self.planner.to_cell(x, y)
            if 0 <= r < self.planner.h and 0 <= c < self.planner.w and self.planner.cost[r, c] == 1:
                return x, y
        return self.base.x, self.base.y

    # --- navigation --------------------------------------------------------------------

    def navigate(self, x: float, y: float, yaw: float, done: Callable[[int], None] | None = None) -> Goal:
        """An internal move_base goal (the navigation node is a move_base client)."""
        pose = {"header": messages.header(ri.MAP_FRAME), "pose": {"position": {"x": x, "y": y, "z": 0.0},
                                                                  "orientation": world.yaw_to_quaternion(yaw)}}
        goal = self.move_base.receive_goal({"goal_id": {"stamp": messages.stamp(),
                                                        "id": self.move_base.new_goal_id()},
                                            "goal": {"target_pose": pose}})
        if goal.status == ACTIVE_STATUS:
            goal.data["done"] = done
        elif done is not None:
            done(goal.status)
        return goal

    def _move_base_goal(self, goal: Goal) -> None:
        pose = goal.goal["target_pose"]["pose"]
        x, y = pose["position"]["x"], pose["position"]["y"]
        yaw = world.quaternion_to_yaw(pose["orientation"])
        t0 = time.perf_counter()
        path = self.planner.plan((self.base.x, self.base.y), (x, y))
        if path is None:
            self.rosout(8, "/move_base", "Failed to get a plan.")
            self._finish_move_base(goal, ABORTED, "Failed to find a valid plan. Even after executing recovery "
                                                  "behaviors.")
            return
        self.rosout(2, "/move_base", f"Got new plan ({len(path)} poses, {1000 * (time.perf_counter() - t0):.0f} ms)")
        self.navigator.start(path, yaw, time.monotonic())
        goal.data["target"] = (x, y, yaw)
        self._pub_plan(force=True)

    def _move_base_cancel(self, goal: Goal) -> None:
        self.navigator.stop(time.monotonic())
        self._pub_plan(force=True)
        done = goal.data.pop("done", None)
        if done is not None:
            done(goal.status)

    def _finish_move_base(self, goal: Goal, status: int, text: str = "") -> None:
        self.move_base.finish(goal, status, text)
        done = goal.data.pop("done", None)
        if done is not None:
            done(status)

    def _navigation_goal(self, goal: Goal) -> None:
        order, name = goal.goal["order"], goal.goal["location_name"]
        if order == "navigation_go_to":
            loc = self.world.locations.get(name)
            if loc is None:
                self.rosout(4, "/cyborg_navigation", f"Unknown location '{name}'")
                self.navigation.finish(goal, ABORTED, f"unknown location {name}", {"status": "aborted"})
                return
            target = (loc.x, loc.y, loc.yaw)
        elif order == "navigation_dock":
            loc = self.world.locations["charging_station"]
            name, target = loc.name, (loc.x, loc.y, loc.yaw)
        elif order == "navigation_wander":
            x, y = self._random_free_point()
            name, target = "", (x, y, 0.0)
        else:
            self.rosout(4, "/cyborg_navigation", f"Unknown navigation order '{order}'")
            self.navigation.finish(goal, ABORTED, f"unknown order {order}", {"status": "aborted"})
            return
        goal.data["location"] = name
        self.navigation.feedback(goal, {"status": f"navigating to {name or 'a random point'}"})

        def done(status: int) -> None:
            text = {SUCCEEDED: "succeeded", PREEMPTED: "preempted"}.get(status, "aborted")
            if goal.status == ACTIVE_STATUS:
                final = status if status in (SUCCEEDED, PREEMPTED) else ABORTED
                self.navigation.finish(goal, final, text, {"status": text})

        goal.data["move_base_goal"] = self.navigate(*target, done)

    def _navigation_cancel(self, goal: Goal) -> None:
        mb = goal.data.get("move_base_goal")
        if mb is not None and mb.status == ACTIVE_STATUS:
            mb.data.pop("done", None)
            self.move_base.receive_cancel({"id": mb.id, "stamp": {"secs": 0, "nsecs": 0}})

    # --- the tick ------------------------------------------------------------------------

    async def _tick_loop(self) -> None:
        last = time.monotonic()
        next_t = last
        while True:
            next_t += self.tick_s
            delay = next_t - time.monotonic()
            if delay < -1.0:  # fell far behind (host paused): do not try to catch up
                next_t = time.monotonic()
            await asyncio.sleep(max(0.0, delay))
            now = time.monotonic()
            dt, last = min(now - last, 0.2), now
            try:
                self._tick(now, dt)
            except Exception:
                log.exception("simulator tick failed")

    def _tick(self, now: float, dt: float) -> None:
        if self.base.step(dt, now):
            self.bumper_until = now + 0.5
            self._pub_bumper()
            self._warn_once("bump", "/RosAria", "Bumper pressed: the robot hit an obstacle")
        result = self.navigator.step(now)
        goal = self.move_base.current
        if result != "running" and goal is not None:
            if result == "succeeded":
                self._finish_move_base(goal, SUCCEEDED, "Goal reached.")
            else:
                self.rosout(8, "/move_base", "Aborting because a valid control could not be found.")
                self._finish_move_base(goal, ABORTED, "Robot is unable to make progress")
            self._pub_plan(force=True)
        self._battery(dt)
        self.emotions.drift(dt)
        if self._state_deadline is not None and now >= self._state_deadline:
            self._state_deadline = None
            self._state_timer()
        for s in self._schedules:
            if now >= s.due:
                s.due = s.due + s.period if now - s.due < s.period else now + s.period
                s.fn()

    def voltage(self) -> float:
        # A 24 V nominal pack (Pioneer LX): ~23 V empty, ~26 V full, +1.2 V while charging.
        return 23.0 + 3.0 * self.soc + (1.2 if self.recharge_state > 0 else 0.0)

    def _battery(self, dt: float) -> None:
        dock = self.world.locations.get("charging_station")
        docked = dock is not None and math.hypot(self.base.x - dock.x, self.base.y - dock.y) < dock.threshold \
            and self.base.v == 0.0
        if docked:
            self.soc = min(1.0, self.soc + self.charge * dt)
            self.recharge_state = 1 if self.soc < 0.9 else 3
        else:
            moving = abs(self.base.v) + 0.3 * abs(self.base.w)
            self.soc = max(0.0, self.soc - self.drain * (1.0 + 4.0 * moving) * dt)
            self.recharge_state = 0
        if self.soc < 0.2 and not docked:
            self._warn_once("battery_low", "/RosAria", f"Battery low: {100 * self.soc:.0f}%", 60.0)
            if not self._low_battery_fired and self.sm.accepts("power_low"):
                self._low_battery_fired = True
                self.rosout(2, "/cyborg_eventscheduler", "Battery low: power_low")
                self.fire("power_low")
        elif self.soc > 0.3:
            self._low_battery_fired = False

    # --- periodic publishers ---------------------------------------------------------------

    def _pose(self) -> dict[str, Any]:
        b = self.base
        return {"position": {"x": b.x, "y": b.y, "z": 0.0}, "orientation": world.yaw_to_quaternion(b.yaw)}

    def _pub_pose(self) -> None:
        if self._wants("robot_pose"):
            self._publish("robot_pose", self._pose())
        if self._wants("odom"):
            b = self.base
            cov = [0.0] * 36
            self._publish("odom", {
                "header": messages.header("odom", time.time()), "child_frame_id": "base_link",
                "pose": {"pose": {"position": {"x": b.odom_x, "y": b.odom_y, "z": 0.0},
                                  "orientation": world.yaw_to_quaternion(b.odom_yaw)}, "covariance": cov},
                "twist": {"twist": {"linear": {"x": b.v, "y": 0.0, "z": 0.0},
                                    "angular": {"x": 0.0, "y": 0.0, "z": b.w}}, "covariance": cov},
            })

    @staticmethod
    def _transform(parent: str, child: str, x: float, y: float, yaw: float) -> dict[str, Any]:
        return {"header": messages.header(parent), "child_frame_id": child,
                "transform": {"translation": {"x": x, "y": y, "z": 0.0}, "rotation": world.yaw_to_quaternion(yaw)}}

    def _pub_tf(self) -> None:
        if not self._wants("tf"):
            return
        b = self.base
        # map->odom is whatever makes map->odom->base_link equal the true pose.
        dyaw = world.wrap(b.yaw - b.odom_yaw)
        c, s = math.cos(dyaw), math.sin(dyaw)
        tx = b.x - (c * b.odom_x - s * b.odom_y)
        ty = b.y - (s * b.odom_x + c * b.odom_y)
        self._publish("tf", {"transforms": [
            self._transform("map", "odom", tx, ty, dyaw),
            self._transform("odom", "base_link", b.odom_x, b.odom_y, b.odom_yaw),
        ]})

    def _pub_amcl(self) -> None:
        if self._wants("amcl_pose"):
            cov = [0.0] * 36
            cov[0] = cov[7] = 0.02
            cov[35] = 0.01
            self._publish("amcl_pose", {"header": messages.header(ri.MAP_FRAME),
                                        "pose": {"pose": self._pose(), "covariance": cov}})

    def _pub_particles(self) -> None:
        if not self._wants("particlecloud"):
            return
        b, g = self.base, self.rng.gauss
        poses = [{"position": {"x": b.x + g(0, 0.1), "y": b.y + g(0, 0.1), "z": 0.0},
                  "orientation": world.yaw_to_quaternion(b.yaw + g(0, 0.05))} for _ in range(50)]
        self._publish("particlecloud", {"header": messages.header(ri.MAP_FRAME), "poses": poses})

    def _pub_sonar(self) -> None:
        if not self._wants("sonar"):
            return
        b = self.base
        points = []
        for i in range(8):
            a = -math.pi / 2 + i * math.pi / 7
            d = self.world.raycast(b.x, b.y, b.yaw + a, 5.0)
            points.append({"x": d * math.cos(a), "y": d * math.sin(a), "z": 0.0})
        self._publish("sonar", {"header": messages.header("sonar"), "points": points, "channels": []})

    def _pub_bumper(self) -> None:
        if self._wants("bumper_state"):
            hit = time.monotonic() < self.bumper_until
            front = hit and self.base.cmd_v >= 0
            self._publish("bumper_state", {"header": messages.header("base_link"),
                                           "front_bumpers": [front] * 5, "rear_bumpers": [hit and not front] * 5})

    def _pub_battery(self) -> None:
        self._publish("battery_soc", {"data": self.soc})
        self._publish("battery_voltage", {"data": self.voltage() + self.rng.gauss(0, 0.02)})
        self._publish("battery_recharge_state", {"data": self.recharge_state})

    def _pub_motors(self) -> None:
        self._publish("motors_state", {"data": self.base.motors})

    def _pub_action_status(self) -> None:
        for server in (self.move_base, self.navigation):
            if self.broker.wants(f"{server.name}/status"):
                server.publish_status()
            else:
                server.status_message()  # still expire old goals

    def _pub_plan(self, force: bool = False) -> None:
        if not self._wants("plan") or not (force or self.navigator.active):
            return
        poses = [{"header": messages.header(ri.MAP_FRAME),
                  "pose": {"position": {"x": x, "y": y, "z": 0.0}, "orientation": world.yaw_to_quaternion(0.0)}}
                 for x, y in self.navigator.remaining()]
        self._publish("plan", {"header": messages.header(ri.MAP_FRAME), "poses": poses})

    def _nav_feedback(self) -> None:
        goal = self.move_base.current
        if goal is not None and self.navigator.active:
            self.move_base.feedback(goal, {"base_position": {"header": messages.header(ri.MAP_FRAME),
                                                             "pose": self._pose()}})
        ngoal = self.navigation.current
        if ngoal is not None:
            self.navigation.feedback(ngoal, {"status": f"navigating to {ngoal.data.get('location') or 'a point'}"})

    def _pub_transitions(self) -> None:
        self._publish("state_transitions", {"data": self.sm.transitions_json()})

    def _pub_smach_status(self) -> None:
        if not self._wants("smach_status"):
            return
        for path, initial, active in self.sm.smach_status():
            self._publish("smach_status", {"header": messages.header(), "path": path, "initial_states": initial,
                                           "active_states": active, "local_data": "", "info": ""})

    def _pub_smach_structure(self) -> None:
        if not self._wants("smach_structure"):
            return
        for path, children, edges, outcomes in self.sm.smach_structure():
            self._publish("smach_structure", {
                "header": messages.header(), "path": path, "children": children,
                "internal_outcomes": [e for _, e, _ in edges], "outcomes_from": [f for f, _, _ in edges],
                "outcomes_to": [t for _, _, t in edges], "container_outcomes": outcomes})

    def _on_emotion(self, old: str, new: str, pad: tuple[float, float, float]) -> None:
        if old != new:
            self.rosout(2, "/cyborg_controller", f"Emotional state: {old} -> {new}")
        self._pub_emotion()

    def _pub_emotion(self) -> None:
        self._publish("emotional_state", self.emotions.message())
        self._publish("emotion_system_status", {"data": self.emotions.enabled})

    def _on_spoken(self, text: str) -> None:
        self.rosout(2, "/cyborg_audio", f"Finished speaking: {text}")
        self._publish("tts_feedback", {"data": text})

    def _on_played(self, clip: str) -> None:
        self._publish("playback_feedback", {"data": clip})

    def _pub_location(self) -> None:
        b = self.base
        here = next((n for n, loc in self.world.locations.items()
                     if math.hypot(loc.x - b.x, loc.y - b.y) <= loc.threshold), "")
        if here != self.current_location:
            self.current_location = here
            if here:
                self.rosout(2, "/cyborg_navigation", f"Arrived at {here}")
        self._publish("current_location", {"data": here})

    def _grid_message(self, data: list[int], width: int, height: int, res: float, ox: float, oy: float,
                      frame: str = ri.MAP_FRAME) -> dict[str, Any]:
        return {"header": messages.header(frame), "info": {
            "map_load_time": self._map_load_time, "resolution": res, "width": width, "height": height,
            "origin": {"position": {"x": ox, "y": oy, "z": 0.0}, "orientation": world.yaw_to_quaternion(0.0)}},
            "data": data}

    def _map_message(self) -> dict[str, Any]:
        w = self.world
        return self._grid_message(w.grid.ravel().tolist(), w.width, w.height, w.resolution, w.origin_x, w.origin_y)

    def _pub_global_costmap(self) -> None:
        if not self._wants("global_costmap"):
            return
        p = self.planner
        import numpy as np

        data = np.where(p.cost < 0, 100, np.where(p.cost > 1, 60, 0)).astype(np.int8).ravel().tolist()
        self._publish("global_costmap", self._grid_message(data, p.w, p.h, p.res, self.world.origin_x,
                                                           self.world.origin_y))

    def _pub_local_costmap(self) -> None:
        if not self._wants("local_costmap"):
            return
        w, b, n = self.world, self.base, 60
        r0, c0 = w.cell(b.x - n * w.resolution / 2, b.y - n * w.resolution / 2)
        data = []
        for r in range(r0, r0 + n):
            for c in range(c0, c0 + n):
                inside = 0 <= r < w.height and 0 <= c < w.width
                data.append(100 if inside and w.grid[r, c] == world.OCCUPIED else 0)
        ox, oy = w.origin_x + c0 * w.resolution, w.origin_y + r0 * w.resolution
        self._publish("local_costmap", self._grid_message(data, n, n, w.resolution, ox, oy, "odom"))

    def _chatter(self) -> None:
        node, text = self.rng.choice(CHATTER)
        self.rosout(2, node, text)


ACTIVE_STATUS = 1
