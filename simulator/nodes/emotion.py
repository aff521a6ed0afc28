"""cyborg_controller's emotion system: the PAD state, its presets and drift, and the switches the commander flips."""

from __future__ import annotations

import math
import random
from collections.abc import Callable
from typing import Any

from robot import interface as ri

from ..bus import Bus, SimNode

NODE = "/cyborg_controller"
PAD = tuple[float, float, float]


def _clamp(v: float) -> float:
    return max(-1.0, min(1.0, v))


def nearest(pad: PAD) -> str:
    return min(ri.EMOTION_PRESETS, key=lambda n: math.dist(ri.EMOTION_PRESETS[n], pad))


class EmotionSystem:
    """Publishes through ``emit(from_name, to_name, pad)`` whenever the named emotion changes."""

    DRIFT_PER_S = 0.01  # the motivator's slow pull, per axis
    NOISE_PER_S = 0.02

    def __init__(self, rng: random.Random, emit: Callable[[str, str, PAD], None],
                 initial: str = "unconcerned") -> None:
        self.rng = rng
        self.emit = emit
        self.name = initial
        self.previous = initial
        self.pad: PAD = ri.EMOTION_PRESETS[initial]
        self.enabled = False

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
        self.emit(self.previous, name, pad)

    def message(self) -> dict[str, object]:
        p, a, d = self.pad
        return {"from_emotional_state": self.previous, "to_emotional_state": self.name,
                "current_pleasure": p, "current_arousal": a, "current_dominance": d}


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
