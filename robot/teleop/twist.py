"""Browser input state → a clamped ``geometry_msgs/Twist``. Pure functions, no I/O."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from django.conf import settings


class InvalidInput(ValueError):
    """The browser sent something that must not turn into a Twist."""


@dataclass(frozen=True)
class Limits:
    """Speed limits in m/s and rad/s; the server's settings bound whatever a page asks for."""

    linear: float
    angular: float


@dataclass(frozen=True)
class Command:
    """A velocity command: forward speed (m/s) and turn rate (rad/s, positive = left)."""

    linear: float = 0.0
    angular: float = 0.0

    @property
    def is_zero(self) -> bool:
        return self.linear == 0.0 and self.angular == 0.0


STOP = Command()


def server_limits() -> Limits:
    return Limits(linear=settings.TELEOP_MAX_LINEAR, angular=settings.TELEOP_MAX_ANGULAR)


def _number(content: dict[str, Any], name: str, default: float | None = None) -> float:
    value = content.get(name, default)
    # bool is an int in Python; a JSON true is not a speed.
    if value is None or isinstance(value, bool) or not isinstance(value, int | float):
        raise InvalidInput(f"{name} must be a number")
    value = float(value)
    if not math.isfinite(value):
        raise InvalidInput(f"{name} must be a finite number")
    return value


def _clamp(value: float, low: float, high: float) -> float:
    return max(low, min(high, value))


def command_from_input(content: dict[str, Any], limits: Limits | None = None) -> Command:
    """``{"linear": -1..1, "angular": -1..1, "max_linear", "max_angular"}`` → a clamped Command.

    The stick/key values are normalised; the page's slider maxima scale them, and the
    server limits cap the sliders. Raises InvalidInput for anything non-numeric or non-finite.
    """
    limits = limits or server_limits()
    linear = _clamp(_number(content, "linear"), -1.0, 1.0)
    angular = _clamp(_number(content, "angular"), -1.0, 1.0)
    max_linear = _clamp(_number(content, "max_linear", limits.linear), 0.0, limits.linear)
    max_angular = _clamp(_number(content, "max_angular", limits.angular), 0.0, limits.angular)
    # 0.0 rather than -0.0 so a zero command compares and serialises as zero.
    return Command(linear=linear * max_linear + 0.0, angular=angular * max_angular + 0.0)


def twist(command: Command) -> dict[str, Any]:
    """The ``geometry_msgs/Twist`` message for a command (planar base: x forward, z yaw)."""
    return {
        "linear": {"x": command.linear, "y": 0.0, "z": 0.0},
        "angular": {"x": 0.0, "y": 0.0, "z": command.angular},
    }
