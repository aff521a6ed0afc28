"""The controller's emotion system: PAD values, presets, drift while on."""

from __future__ import annotations

import math
import random
from collections.abc import Callable

from robot import interface as ri

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
