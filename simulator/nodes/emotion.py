"""cyborg_controller's emotion system: the PAD state, its drift, and the switches the commander flips."""

from __future__ import annotations

import random
from typing import Any

from robot import interface as ri

from ..bus import Bus, SimNode
from ..emotions import PAD, EmotionSystem

NODE = "/cyborg_controller"


class EmotionNode(SimNode):
    names = ()  # part of /cyborg_controller (ControllerNode names it)
    publishes = ("emotional_state", "emotion_system_status")
    answers = ("get_emotional_state",)

    def __init__(self, rng: random.Random) -> None:
        self.emotions = EmotionSystem(rng, self._on_emotion)

    def start(self, bus: Bus) -> None:
        super().start(bus)
        bus.on("emotional_controller", self._emotional_controller)
        bus.on("set_emotional_state", self._set_emotion)
        bus.on("emotional_feedback", lambda m: self.emotions.feedback(m["delta_pleasure"], m["delta_arousal"],
                                                                     m["delta_dominance"]))
        bus.answer("get_emotional_state", self._get_emotional_state)
        bus.each_tick(lambda now, dt: self.emotions.drift(dt))
        bus.every(1.0, self._publish)

    def _emotional_controller(self, m: dict[str, Any]) -> None:
        value = m["data"]
        if value.upper() not in (ri.EMOTION_SYSTEM_ON, ri.EMOTION_SYSTEM_OFF):
            self.bus.rosout(4, NODE, f"Emotion system switch '{value}' not understood (ON/OFF)")
            return
        self.emotions.enabled = value.upper() == ri.EMOTION_SYSTEM_ON
        self.bus.rosout(2, NODE, f"Emotion system {'on' if self.emotions.enabled else 'off'}")
        self.bus.publish("emotion_system_status", {"data": self.emotions.enabled})

    def _set_emotion(self, m: dict[str, Any]) -> None:
        if not self.emotions.set(m["data"]):
            self.bus.rosout(4, NODE, f"Unknown emotional state '{m['data']}': ignored")

    def _get_emotional_state(self, r: dict[str, Any]) -> dict[str, Any]:
        p, a, d = self.emotions.pad
        return {"emotional_state": self.emotions.name, "current_pleasure": p, "current_arousal": a,
                "current_dominance": d}

    def _on_emotion(self, old: str, new: str, pad: PAD) -> None:
        if old != new:
            self.bus.rosout(2, NODE, f"Emotional state: {old} -> {new}")
        self._publish()

    def _publish(self) -> None:
        self.bus.publish("emotional_state", self.emotions.message())
        self.bus.publish("emotion_system_status", {"data": self.emotions.enabled})
