"""Reconnect the robot link now instead of after its backoff (the pages' button): an operator's
command, audited like any other; the link takes at most one every few seconds (429 otherwise),
since a link kept flapping could not carry an E-STOP."""

from __future__ import annotations

from typing import Any

from robot.commands.pipeline import arun_command
from robot.link.bus import arequest


async def reconnect(*, user: Any, source: str) -> str:
    async def run() -> str:
        await arequest("reconnect", timeout=2)
        return "reconnect requested"

    return await arun_command(user=user, source=source, action="link.reconnect", params={}, run=run,
                              refusal="Only operators can reconnect the robot link.")
