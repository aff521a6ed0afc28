"""RosAria's diagnostic_updater on ``/diagnostics``, read from the simulated world: the
battery's charge, the motors, the bumpers, the laser and the sonar.

``statuses`` turns one ``Reading`` of the robot into ``DiagnosticStatus`` entries; the node polls
a few times a second and publishes them once a second, and at once when a level changes (a motor
switched off, a bump).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from robot import interface as ri

from .. import messages
from ..bus import Bus, SimNode
from .base import BaseNode
from .laser import MOUNT as LASER_MOUNT
from .laser import Laser

HARDWARE_ID = "Pioneer LX (simulated)"
LASER_ID = "SICK S300 (simulated)"
BATTERY_WARN_SOC = 0.2
BATTERY_ERROR_SOC = 0.05
LASER_CLOSE_M = 0.25  # nearer than this the robot is about to touch something
PERIOD_S = 1.0
POLL_S = 0.1
# What the laser covers (where it sits on base_link: laser.MOUNT, as the base's /tf_static says).
LASER_FOV, LASER_MAX_M = Laser.angle_max - Laser.angle_min, Laser.range_max


@dataclass(frozen=True)
class Reading:
    soc: float
    voltage: float
    recharge_state: int
    motors: bool
    v: float
    w: float
    cmd_v: float
    cmd_w: float
    front_bumped: bool
    rear_bumped: bool
    laser_nearest_m: float
    laser_max_m: float
    sonar_nearest_m: float


def _status(level: int, message: str, name: str, hardware_id: str, **values: object) -> dict[str, Any]:
    return {"level": level, "name": name, "message": message, "hardware_id": hardware_id,
            "values": [{"key": k.replace("_", " "), "value": str(v)} for k, v in values.items()]}


def statuses(r: Reading) -> list[dict[str, Any]]:
    ok, warn, error = ri.DIAGNOSTIC_OK, ri.DIAGNOSTIC_WARN, ri.DIAGNOSTIC_ERROR
    pct = 100 * r.soc
    if r.soc < BATTERY_ERROR_SOC:
        battery = (error, f"Battery critical: {pct:.0f}%")
    elif r.soc < BATTERY_WARN_SOC:
        battery = (warn, f"Battery low: {pct:.0f}%")
    else:
        battery = (ok, "Charging" if r.recharge_state > 0 else "Discharging")
    stalled = r.motors and r.cmd_v != 0.0 and r.v == 0.0 and (r.front_bumped or r.rear_bumped)
    if not r.motors:
        motors = (warn, "Motors disabled")
    elif stalled:
        motors = (error, "Stalled against an obstacle")
    else:
        motors = (ok, "Motors enabled")
    pressed = [side for side, on in (("front", r.front_bumped), ("rear", r.rear_bumped)) if on]
    bumpers = (warn, f"{' and '.join(pressed).capitalize()} bumper pressed") if pressed else (ok, "Clear")
    laser = ((warn, f"Obstacle within {LASER_CLOSE_M:.2f} m") if r.laser_nearest_m < LASER_CLOSE_M
             else (ok, "Scanning"))
    return [
        _status(*battery, "RosAria: Battery", HARDWARE_ID, state_of_charge=f"{pct:.1f} %",
                voltage=f"{r.voltage:.2f} V", recharge_state=ri.RECHARGE_STATES.get(r.recharge_state, "unknown")),
        _status(*motors, "RosAria: Motors", HARDWARE_ID, enabled=r.motors, linear_velocity=f"{r.v:.2f} m/s",
                angular_velocity=f"{r.w:.2f} rad/s", commanded_linear=f"{r.cmd_v:.2f} m/s"),
        _status(*bumpers, "RosAria: Bumpers", HARDWARE_ID, front=r.front_bumped, rear=r.rear_bumped),
        _status(*laser, "Laser: front scanner", LASER_ID, nearest_obstacle=f"{r.laser_nearest_m:.2f} m",
                range_max=f"{r.laser_max_m:.1f} m"),
        _status(ok, "Ranging", "RosAria: Sonar", HARDWARE_ID, nearest_echo=f"{r.sonar_nearest_m:.2f} m"),
    ]


class DiagnosticsNode(SimNode):
    names: tuple[str, ...] = ()  # RosAria publishes them (the base node names /RosAria)
    publishes = ("diagnostics",)

    def __init__(self, base: BaseNode) -> None:
        self.base = base
        self._levels: list[tuple[str, int, str]] = []
        self._sent_at = float("-inf")

    def start(self, bus: Bus) -> None:
        super().start(bus)
        bus.every(POLL_S, self._poll)

    def _poll(self) -> None:
        msg = self.poll(self.read(), self.bus.clock.now())
        if msg is not None:
            self.bus.publish("diagnostics", msg)

    def poll(self, reading: Reading, now: float) -> dict[str, Any] | None:
        """The message to publish when a second has passed or a level moved, else None."""
        current = statuses(reading)
        levels = [(s["name"], s["level"], s["message"]) for s in current]
        if levels == self._levels and now - self._sent_at < PERIOD_S:
            return None
        self._levels, self._sent_at = levels, now
        return {"header": messages.header(), "status": current}

    def read(self) -> Reading:
        base, b = self.base, self.base.body
        front, rear = base.bumpers()
        laser = base.world.fan(b, LASER_MOUNT[0], LASER_FOV, 19, LASER_MAX_M)
        return Reading(
            soc=base.soc, voltage=base.voltage(), recharge_state=base.recharge_state, motors=b.motors,
            v=b.v, w=b.w, cmd_v=b.cmd_v, cmd_w=b.cmd_w, front_bumped=front, rear_bumped=rear,
            laser_nearest_m=min(d for _, d in laser), laser_max_m=LASER_MAX_M,
            sonar_nearest_m=min(d for _, d in base.sonar()),
        )
