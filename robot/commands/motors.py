"""Motors on/off through the RosAria services; the caller sees the service's own answer. While the
robot says its motors are off, what would move it (driving, goals) is refused with that reason."""

from __future__ import annotations

from typing import Any

from robot import interface as ri
from robot.commands.pipeline import Command
from robot.commands.validation import clean_bool
from robot.link import bus
from robot.live.announce import aget_state


class MotorsOff(bus.RobotError):
    status_code = 409
    code = "motors_off"


async def ensure_motors_on(what: str) -> None:
    """Refuse ``what`` while the robot's latest ``motors_state`` says off (an E-STOP leaves them off): it
    would be accepted and go nowhere. Unknown (nothing heard yet) is not refused."""
    state = (await aget_state("motors_state")).get("motors_state")
    if state is not None and state.get("data") is False:
        raise MotorsOff(f"Motors off: {what} is refused until the motors are enabled (press Enable).")


def set_motors(enabled: Any) -> Command:
    async def send(on: bool) -> str:
        key = "enable_motors" if on else "disable_motors"
        try:
            await bus.acall_service(key)
        except bus.RobotError as exc:
            if type(exc) is bus.RobotError:  # a failed service_response: say which service refused
                raise bus.RobotError(f"{ri.service(key).name} failed: {exc.message}") from exc
            raise
        return f"Motors {'enabled' if on else 'disabled'} ({ri.service(key).name} ok)"

    return Command("motors", {"enabled": enabled}, send, check=lambda: clean_bool(enabled, "enabled"),
                   check_on_loop=True)
