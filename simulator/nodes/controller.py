"""cyborg_controller, cyborg_behavior and cyborg_eventscheduler: the state machine and what each state does.

A state entered runs its behaviour preset (dome, speech, clip, emotional feedback), arms
its timer, or sends the robot somewhere through the navigation node.
"""

from __future__ import annotations

import math
import random
from typing import Any

from .. import messages
from ..actions import SUCCEEDED, Goal
from ..bus import Bus, SimNode
from ..statemachine import NAVIGATION_LEAVES, StateMachine
from .audiovisual import AudioVisualNode
from .emotion import EmotionNode
from .navigation import NavigationNode

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
                self.av.audio.say(preset["say"])
            if "clip" in preset:
                self.av.audio.play(preset["clip"])
            if "pad" in preset:
                self.emotion.emotions.feedback(*preset["pad"])
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
