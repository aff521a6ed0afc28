"""cyborg_controller, cyborg_behavior and cyborg_eventscheduler: the SMACH state machine and what each state does;
cyborg_commander: a robot mode run as its sequence of events, pauses and emotion-system switches.

The state machine follows ROBOT_INTERFACE.md, "The state machine". States are tracked as leaf
names; the behaviour container and, inside it, the navigation container are flattened into their
leaves. ``state_change`` names the leaf entered, so entering behaviour reports ``idle`` (SMACH runs
the container's initial state). A state entered runs its behaviour preset (dome, speech, clip,
emotional feedback), arms its timer, or sends the robot somewhere through the navigation node.
"""

from __future__ import annotations

import asyncio
import json
import math
import random
from collections.abc import Callable
from typing import Any

from robot import interface as ri

from .. import messages
from ..actions import SUCCEEDED, Goal
from ..bus import Bus, SimNode
from .audiovisual import AudioVisualNode
from .emotion import EmotionNode
from .navigation import NavigationNode

SUSPENSION = "suspension"
LEAVE = SUSPENSION  # leaving the behaviour container ends in suspension

TOP: dict[str, dict[str, str]] = {
    "startup": {"succeeded": SUSPENSION, "aborted": SUSPENSION},
    "suspension": {"behaviour_start": "idle", "restart": "startup", "demo_start": "demo",
                   "manual_start": "manual", "aborted": SUSPENSION, "succeeded": SUSPENSION},
    "demo": {"succeeded": SUSPENSION, "aborted": SUSPENSION},
    "manual": {"succeeded": SUSPENSION, "aborted": SUSPENSION},
}

_BACK = {"succeeded": "idle", "aborted": "idle"}
_NAV_OUT = {"succeeded": "idle", "aborted": "idle", "power_low": "exhausted"}
NAVIGATION_LEAVES = ("navigation_planning", "navigation_go_to_emotional", "navigation_go_to_schedular",
                     "wandering_emotional")

BEHAVIOUR: dict[str, dict[str, str]] = {
    "idle": {"suspend": LEAVE, "navigation_schedular": "navigation_planning",
             "navigation_emotional": "navigation_planning", "convey_emotion": "conveying_emotional_state",
             "show_off_mea": "show_off_mea", "music_play": "music_horror", "astrolanguage": "astrolanguage",
             "aborted": "idle", "power_low": "exhausted", "bedtime": "sleepy"},
    "show_off_mea": dict(_BACK),
    "conveying_emotional_state": dict(_BACK),
    "music_horror": dict(_BACK),
    "astrolanguage": dict(_BACK),
    "waking_up": dict(_BACK),
    "sleepy": {"aborted": "idle", "succeeded": "sleeping"},
    "exhausted": {"aborted": "idle", "succeeded": "sleeping"},
    "sleeping": {"preempted": "idle", "cyborg_wake_up": "waking_up"},
    # navigation container: planning picks the leaf from the event that entered it
    "navigation_planning": {**_NAV_OUT, "navigation_go_to_emotional": "navigation_go_to_emotional",
                            "navigation_go_to_schedular": "navigation_go_to_schedular",
                            "wandering_emotional": "wandering_emotional"},
    "navigation_go_to_emotional": dict(_NAV_OUT),
    "navigation_go_to_schedular": dict(_NAV_OUT),
    "wandering_emotional": dict(_NAV_OUT),
}

TABLE: dict[str, dict[str, str]] = {**TOP, **BEHAVIOUR}
BEHAVIOUR_STATES = frozenset(BEHAVIOUR)


class StateMachine:
    def __init__(self, on_change: Callable[[str, str, str], None], initial: str = "startup") -> None:
        self.state = initial
        self.on_change = on_change
        self.entered_by: str = ""

    @property
    def top(self) -> str:
        """The top-level state (``behaviour`` for any leaf inside the container)."""
        return "behaviour" if self.state in BEHAVIOUR_STATES else self.state

    def accepts(self, event: str) -> bool:
        return event in TABLE[self.state]

    def fire(self, event: str) -> bool:
        """Apply ``event``; False (nothing happens) if the current state has no such transition."""
        target = TABLE[self.state].get(event)
        if target is None:
            return False
        previous, self.state, self.entered_by = self.state, target, event
        self.on_change(event, previous, target)
        return True

    def transitions_json(self) -> str:
        """What ``state_transitions`` publishes: {event: resulting state} of the state entered.
        Inside the navigation container the container's own name is the observable target."""
        return json.dumps(TABLE[self.state])

    def smach_status(self) -> list[tuple[str, list[str], list[str]]]:
        """(path, initial_states, active_states) of each active container."""
        out = [("/SM_ROOT", ["startup"], [self.top])]
        if self.state in BEHAVIOUR_STATES:
            leaf = "navigation" if self.state in NAVIGATION_LEAVES else self.state
            out.append(("/SM_ROOT/behaviour", ["idle"], [leaf]))
            if self.state in NAVIGATION_LEAVES:
                out.append(("/SM_ROOT/behaviour/navigation", ["navigation_planning"], [self.state]))
        return out

    @staticmethod
    def smach_structure() -> list[tuple[str, list[str], list[tuple[str, str, str]], list[str]]]:
        """(path, children, [(from, outcome, to)], container outcomes) of each container."""
        root = [(s, e, t if t != "idle" else "behaviour") for s, tr in TOP.items() for e, t in tr.items()]
        root.append(("behaviour", "succeeded", SUSPENSION))
        inner = [(s, e, "succeeded" if t == LEAVE else "navigation" if t in NAVIGATION_LEAVES else t)
                 for s, tr in BEHAVIOUR.items() if s not in NAVIGATION_LEAVES for e, t in tr.items()]
        # The navigation leaves end in the navigation container's outcomes, which the behaviour
        # container maps to its states (as SMACH wires a nested container).
        inner += [("navigation", e, t) for e, t in _NAV_OUT.items()]
        nav = [(s, e, t if t in NAVIGATION_LEAVES else e) for s, tr in BEHAVIOUR.items()
               if s in NAVIGATION_LEAVES for e, t in tr.items()]
        behaviour_children = [s for s in BEHAVIOUR if s not in NAVIGATION_LEAVES] + ["navigation"]
        return [
            ("/SM_ROOT", [*TOP, "behaviour"], root, []),
            ("/SM_ROOT/behaviour", behaviour_children, inner, ["succeeded"]),
            ("/SM_ROOT/behaviour/navigation", list(NAVIGATION_LEAVES), nav, ["succeeded", "aborted", "power_low"]),
        ]


NODE = "/cyborg_controller"
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
TIMED_BEHAVIOURS = ("show_off_mea", "conveying_emotional_state", "music_horror", "astrolanguage", "waking_up",
                    "sleepy")
PLANNING_S = 0.3  # navigation_planning picks its leaf after this long


class ControllerNode(SimNode):
    names = (NODE, "/cyborg_behavior", "/cyborg_eventscheduler")
    publishes = ("state_change", "state_transitions", "smach_status", "smach_structure")

    def __init__(self, rng: random.Random, navigation: NavigationNode, audiovisual: AudioVisualNode,
                 emotion: EmotionNode, startup_s: float, demo_s: float, behaviour_s: float) -> None:
        self.rng = rng
        self.nav = navigation
        self.av = audiovisual
        self.emotion = emotion
        # state: how long it lasts before the state timer fires
        self.durations = {"startup": startup_s, "demo": demo_s, "navigation_planning": PLANNING_S,
                          **dict.fromkeys(TIMED_BEHAVIOURS, behaviour_s)}
        self.sm = StateMachine(self._on_state_change)
        self._state_deadline: float | None = None
        self._internal_nav_goal: Goal | None = None

    def start(self, bus: Bus) -> None:
        super().start(bus)
        bus.on("register_event", lambda m: self.fire(m["data"]))
        bus.each_tick(self._step)
        bus.every(5.0, self._pub_transitions)
        bus.every(0.5, self._pub_smach_status)
        bus.every(5.0, self._pub_smach_structure, wanted="smach_structure")
        self._on_state_change("", "", self.sm.state)

    def fire(self, event: str) -> bool:
        if self.sm.fire(event):
            return True
        self.bus.rosout(4, NODE, f"Event '{event}' is not a transition of state '{self.sm.state}': ignored")
        return False

    def battery_low(self) -> bool:
        """The event scheduler on a low battery: "power_low" if the state machine takes it now."""
        if not self.sm.accepts("power_low"):
            return False
        self.bus.rosout(2, "/cyborg_eventscheduler", "Battery low: power_low")
        self.fire("power_low")
        return True

    def _step(self, now: float, dt: float) -> None:
        """The state timer: a timed state ends, or navigation_planning picks its leaf."""
        if self._state_deadline is None or now < self._state_deadline:
            return
        self._state_deadline = None
        if self.sm.state != "navigation_planning":
            self.fire("succeeded")
        elif self.sm.entered_by == "navigation_schedular":
            self.fire("navigation_go_to_schedular")
        else:
            self.fire("navigation_go_to_emotional" if self.rng.random() < 0.5 else "wandering_emotional")

    def _on_state_change(self, event: str, old: str, new: str) -> None:
        now = self.bus.clock.now()
        self._state_deadline = None
        if event:
            self.bus.rosout(2, NODE, f"State transition: {old} --[{event}]--> {new}")
        self.bus.publish("state_change", {"event": event, "from_system_state": old, "to_system_state": new})
        self._pub_transitions()
        self._pub_smach_status()
        leaving_nav = (old in NAVIGATION_LEAVES or old == "exhausted") and new not in NAVIGATION_LEAVES
        if leaving_nav and self._internal_nav_goal is not None:
            goal, self._internal_nav_goal = self._internal_nav_goal, None
            self.nav.cancel(goal)
        preset = BEHAVIOUR_PRESETS.get(new)
        if preset and old != new:
            if "visual" in preset:
                self.av.dome_mode = preset["visual"]
            if "say" in preset:
                self.av.say(preset["say"])
            if "clip" in preset:
                self.av.play(preset["clip"])
            if "pad" in preset:
                self.emotion.feedback(*preset["pad"])
        if new in self.durations:
            self._state_deadline = now + self.durations[new]
        elif new in NAVIGATION_LEAVES:  # the leaves that go somewhere (planning is timed)
            self._behaviour_navigate(new)
        elif new == "exhausted":
            self._behaviour_navigate(new, "charging_station")

    def _behaviour_navigate(self, state: str, location: str | None = None) -> None:
        places = self.nav.world.locations
        if location is None:
            location = self.rng.choice(sorted(n for n in places if n != "charging_station"))
        loc = places[location]
        if state == "wandering_emotional":
            x, y = self.nav.random_free_point()
            target = (x, y, self.rng.uniform(-math.pi, math.pi))
        else:
            target = (loc.x, loc.y, loc.yaw)
        where = "somewhere" if state == "wandering_emotional" else location
        self.bus.rosout(2, "/cyborg_navigation", f"{state}: heading to {where}")

        def done(status: int) -> None:
            self._internal_nav_goal = None
            if self.sm.state == state:
                self.fire("succeeded" if status == SUCCEEDED else "aborted")

        self._internal_nav_goal = self.nav.navigate(*target, done)

    def _pub_transitions(self) -> None:
        self.bus.publish("state_transitions", {"data": self.sm.transitions_json()})

    def _pub_smach_status(self) -> None:
        if not self.bus.wants("smach_status"):
            return
        for path, initial, active in self.sm.smach_status():
            self.bus.publish("smach_status", {"header": messages.header(), "path": path, "initial_states": initial,
                                              "active_states": active, "local_data": "", "info": ""})

    def _pub_smach_structure(self) -> None:
        for path, children, edges, outcomes in self.sm.smach_structure():
            self.bus.publish("smach_structure", {
                "header": messages.header(), "path": path, "children": children,
                "internal_outcomes": [e for _, e, _ in edges], "outcomes_from": [f for f, _, _ in edges],
                "outcomes_to": [t for _, _, t in edges], "container_outcomes": outcomes})


COMMANDER = "/cyborg_commander"


class CommanderNode(SimNode):
    names = (COMMANDER,)
    publishes = ()  # it announces on the controller's own topics (register_event, emotional_controller)

    def __init__(self, pause_s: float) -> None:
        self.pause_s = pause_s
        self.mode = ""  # the last robot_mode it ran
        self._queue: asyncio.Queue[str] = asyncio.Queue()

    def start(self, bus: Bus) -> None:
        super().start(bus)
        bus.on("robot_mode", lambda m: self._queue.put_nowait(m["data"]))
        bus.spawn(self._run())

    async def _run(self) -> None:
        while True:
            name = await self._queue.get()
            try:
                mode = ri.Mode(name)
            except ValueError:
                self.bus.rosout(4, COMMANDER, f"Unknown robot mode '{name}'")
                continue
            self.mode = mode.value
            self.bus.rosout(2, COMMANDER, f"Robot mode: {mode.value}")
            for kind, value in ri.COMMANDER_SEQUENCES[mode]:
                if kind == "pause":
                    await self.bus.clock.sleep(self.pause_s)  # every pause in the sequences is this one
                elif kind == "event":
                    self.bus.announce("register_event", {"data": str(value)})
                elif kind == "emotion_system":
                    on = ri.EMOTION_SYSTEM_ON if value else ri.EMOTION_SYSTEM_OFF
                    self.bus.announce("emotional_controller", {"data": on})
