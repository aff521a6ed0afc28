"""cyborg_controller's emotion system: the PAD state, its presets and drift, and the switches the commander flips."""

from __future__ import annotations

import math
import random
from typing import Any

from robot import interface as ri

from ..bus import Bus, SimNode

NODE = "/cyborg_controller"
PAD = tuple[float, float, float]


def _clamp(v: float) -> float:
    return max(-1.0, min(1.0, v))


def nearest(pad: PAD) -> str:
    return min(ri.EMOTION_PRESETS, key=lambda n: math.dist(ri.EMOTION_PRESETS[n], pad))


class EmotionNode(SimNode):
    """The PAD state: set by name, nudged by feedback, drifting while the system is on; published on
    every change of the named emotion."""

    names = ()  # part of /cyborg_controller (ControllerNode names it)
    publishes = ("emotional_state", "emotion_system_status")
    answers = ("get_emotional_state",)
    DRIFT_PER_S = 0.01  # the motivator's slow pull, per axis
    NOISE_PER_S = 0.02

    def __init__(self, rng: random.Random, initial: str = "unconcerned") -> None:
        self.rng = rng
        self.name = initial
        self.previous = initial
        self.pad: PAD = ri.EMOTION_PRESETS[initial]
        self.enabled = False

    def start(self, bus: Bus) -> None:
        super().start(bus)
        bus.on("emotional_controller", self._emotional_controller)
        bus.on("set_emotional_state", self._set_emotion)
        bus.on("emotional_feedback", lambda m: self.feedback(m["delta_pleasure"], m["delta_arousal"],
                                                             m["delta_dominance"]))
        bus.answer("get_emotional_state", self._get_emotional_state)
        bus.each_tick(lambda now, dt: self.drift(dt))
        bus.every(1.0, self._publish)

    def set(self, name: str) -> bool:
        if name not in ri.EMOTION_PRESETS:
            return False
        self._change(name, ri.EMOTION_PRESETS[name])
        return True

    def feedback(self, dp: float, da: float, dd: float) -> None:
        p, a, d = self.pad
        pad = (_clamp(p + dp), _clamp(a + da), _clamp(d + dd))
        self._change(nearest(pad), pad)

    def drift(self, dt: float) -> None:
        if not self.enabled:
            return
        # The motivator lowers arousal and pleasure over time (the robot gets bored).
        p, a, d = self.pad
        n = self.NOISE_PER_S * dt
        pad = (
            _clamp(p - self.DRIFT_PER_S * dt + self.rng.uniform(-n, n)),
            _clamp(a - self.DRIFT_PER_S * dt + self.rng.uniform(-n, n)),
            _clamp(d + self.rng.uniform(-n, n)),
        )
        name = nearest(pad)
        if name != self.name:
            self._change(name, pad)
        else:
            self.pad = pad

    def _change(self, name: str, pad: PAD) -> None:
        self.previous, self.name, self.pad = self.name, name, pad
        if self.previous != name:
            self.bus.rosout(2, NODE, f"Emotional state: {self.previous} -> {name}")
        self._publish()

    def _emotional_controller(self, m: dict[str, Any]) -> None:
        value = m["data"]
        if value.upper() not in (ri.EMOTION_SYSTEM_ON, ri.EMOTION_SYSTEM_OFF):
            self.bus.rosout(4, NODE, f"Emotion system switch '{value}' not understood (ON/OFF)")
            return
        self.enabled = value.upper() == ri.EMOTION_SYSTEM_ON
        self.bus.rosout(2, NODE, f"Emotion system {'on' if self.enabled else 'off'}")
        self.bus.publish("emotion_system_status", {"data": self.enabled})

    def _set_emotion(self, m: dict[str, Any]) -> None:
        if not self.set(m["data"]):
            self.bus.rosout(4, NODE, f"Unknown emotional state '{m['data']}': ignored")

    def _get_emotional_state(self, r: dict[str, Any]) -> dict[str, Any]:
        p, a, d = self.pad
        return {"emotional_state": self.name, "current_pleasure": p, "current_arousal": a, "current_dominance": d}

    def _publish(self) -> None:
        p, a, d = self.pad
        self.bus.publish("emotional_state", {"from_emotional_state": self.previous, "to_emotional_state": self.name,
                                             "current_pleasure": p, "current_arousal": a, "current_dominance": d})
        self.bus.publish("emotion_system_status", {"data": self.enabled})
