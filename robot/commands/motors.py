"""Motors on/off through the RosAria services; the caller sees the service's own answer."""

from __future__ import annotations

from typing import Any

from robot import interface as ri
from robot.commands.pipeline import Command
from robot.commands.validation import clean_bool
from robot.link import bus


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
