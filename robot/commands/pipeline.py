"""The one path every command takes, from a page, the API, a websocket or a task:
check the role, check the input, send it, write the audit entry, and hand back a clear
outcome or error.

A command is a ``Command``: ``check`` validates the input *before* anything is sent (it may
read the database, e.g. preset names) and ``send`` does the robot work on the event loop.
Two faces run it: ``run_command`` for synchronous callers (API views, the admin) keeps the
role check, ``check`` and the audit write in the caller's thread and crosses to the event
loop once, for ``send``; ``arun`` for asynchronous callers (websockets, tasks) hops to a
thread for the database work instead.
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from typing import Any

from asgiref.sync import async_to_sync, sync_to_async

from cyborg_site.roles import is_operator
from robot.commands.audit import audit_record
from robot.link.bus import RobotError

# Not database_sync_to_async: it closes the calling thread's connection, which for a
# synchronous caller (a DRF view) is the request's own connection.
_record = sync_to_async(audit_record, thread_sensitive=True)


class Forbidden(RobotError):
    status_code = 403
    code = "forbidden"


class InvalidCommand(RobotError):
    status_code = 400
    code = "invalid"

    def __init__(self, message: str, *, field: str | None = None) -> None:
        super().__init__(message)
        self.field = field


class Busy(RobotError):
    status_code = 409
    code = "busy"


def _unchecked() -> None:
    return None


FORBIDDEN = "Your role may not command the robot (operators and admins can)."


@dataclass
class Command:
    """What to audit (``action``, ``params``), how to check the input and how to send it.

    ``send`` gets what ``check`` returned and returns the outcome for a person; whatever else
    a caller needs back (a goal, a report) it leaves in ``result``.
    """

    action: str
    params: dict[str, Any]
    send: Callable[[Any], Awaitable[str | None]]
    check: Callable[[], Any] = _unchecked
    allowed: Callable[[Any], bool] = is_operator
    refusal: str = FORBIDDEN  # what a person whose role ``allowed`` refuses is told
    result: dict[str, Any] = field(default_factory=dict)


def run_command(command: Command, *, user: Any, source: str) -> str:
    """The synchronous face: one hop onto the event loop, for ``send``."""
    audit = {"user": user, "source": source, "action": command.action, "params": command.params}
    if not command.allowed(user):
        error = Forbidden(command.refusal)
        audit_record(**audit, ok=False, outcome=error.message, error_code=error.code)
        raise error
    try:
        checked = command.check()
        outcome = async_to_sync(command.send)(checked) or "ok"
    except RobotError as exc:
        audit_record(**audit, ok=False, outcome=exc.message, error_code=exc.code)
        raise
    audit_record(**audit, ok=True, outcome=outcome)
    return outcome


async def arun(command: Command, *, user: Any, source: str) -> str:
    """The asynchronous face: the database work (role, check, audit) runs in a thread."""
    audit = {"user": user, "source": source, "action": command.action, "params": command.params}
    # The role check may query the user's groups: never from the event loop itself.
    if not await sync_to_async(command.allowed, thread_sensitive=True)(user):
        error = Forbidden(command.refusal)
        await _record(**audit, ok=False, outcome=error.message, error_code=error.code)
        raise error
    try:
        checked = None if command.check is _unchecked else await sync_to_async(command.check, thread_sensitive=True)()
        outcome = await command.send(checked) or "ok"
    except RobotError as exc:
        await _record(**audit, ok=False, outcome=exc.message, error_code=exc.code)
        raise
    await _record(**audit, ok=True, outcome=outcome)
    return outcome


async def arun_command(
    *,
    user: Any,
    source: str,
    action: str,
    params: dict[str, Any],
    run: Callable[[], Awaitable[str | None]],
    allowed: Callable[[Any], bool] = is_operator,
    refusal: str = FORBIDDEN,
) -> str:
    """Run ``run`` for ``user`` if allowed; audit the outcome; return a human-readable result."""

    async def send(_: Any) -> str | None:
        return await run()

    return await arun(Command(action, params, send, allowed=allowed, refusal=refusal), user=user, source=source)


async def arecord_invalid(*, user: Any, source: str, action: str, params: dict[str, Any], error: str) -> None:
    """Audit a command refused for bad input (nothing was sent)."""
    await _record(
        user=user, source=source, action=action, params=params, ok=False, outcome=error, error_code="invalid"
    )
