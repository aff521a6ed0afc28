"""The one path every command takes, from a page, the API, a websocket or a task:
check the role, run it, write the audit entry, and hand back a clear outcome or error.

Validation belongs to the caller (serializers, form parsing) or to the command function
itself by raising ``InvalidCommand`` *before* anything is sent to the robot.
"""

from __future__ import annotations

from collections.abc import Awaitable, Callable
from typing import Any

from asgiref.sync import async_to_sync, sync_to_async

from cyborg_site.roles import is_operator
from robot.commands.audit import audit_record
from robot.link.bus import RobotError

# Not database_sync_to_async: it closes the calling thread's connection, which for a
# synchronous caller (a DRF view calling run_command) is the request's own connection.
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


async def arun_command(
    *,
    user: Any,
    source: str,
    action: str,
    params: dict[str, Any],
    run: Callable[[], Awaitable[str | None]],
    allowed: Callable[[Any], bool] = is_operator,
) -> str:
    """Run ``run`` for ``user`` if allowed; audit the outcome; return a human-readable result."""
    record = _record
    # The role check may query the user's groups: never from the event loop itself.
    if not await sync_to_async(allowed, thread_sensitive=True)(user):
        error = Forbidden("Your role may not command the robot (operators and admins can).")
        await record(user=user, source=source, action=action, params=params, ok=False,
                     outcome=error.message, error_code=error.code)
        raise error
    try:
        outcome = await run() or "ok"
    except RobotError as exc:
        await record(user=user, source=source, action=action, params=params, ok=False,
                     outcome=exc.message, error_code=exc.code)
        raise
    await record(user=user, source=source, action=action, params=params, ok=True, outcome=outcome)
    return outcome


def run_command(**kwargs: Any) -> str:
    return async_to_sync(arun_command)(**kwargs)


async def arecord_invalid(*, user: Any, source: str, action: str, params: dict[str, Any], error: str) -> None:
    """Audit a command refused for bad input (nothing was sent)."""
    await _record(
        user=user, source=source, action=action, params=params, ok=False, outcome=error, error_code="invalid"
    )
