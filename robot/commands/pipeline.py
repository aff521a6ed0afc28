"""The one path every command takes, from a page, the API, a websocket or a task:
check the role, check the input, refuse it under the E-STOP if it moves the robot
(``robot.estop.rule``), send it, write the audit entry, and hand back a clear outcome or error.

A command is a ``Command``: ``check`` validates the input *before* anything is sent (it may
read the database, e.g. preset names) and ``send`` does the robot work on the event loop.

Each face crosses between the request's thread and the event loop at most once on the way
to the robot, because every crossing queues behind whatever else that thread or loop is doing:

- ``run_command``, the synchronous face (API views, the admin): the role check, ``check``
  and the audit entry run in the caller's thread, where Django's ORM is at home; ``send``
  crosses to the event loop once. API views are synchronous for this reason
  (``robot.api.base``).
- ``arun``, the asynchronous face (websockets, tasks): ``send`` runs where it is. The role
  check reads groups the user object caches (``cyborg_site.roles``); a websocket consumer reads
  them when it connects. With those, and a ``check`` that reads no
  database (``check_on_loop``), everything before sending runs on the loop and the only hop is
  the audit write, on the audit writer's long-lived thread (``robot.commands.audit_writer``).
  Otherwise the role check and ``check`` run together in one thread hop before sending.
"""

from __future__ import annotations

import asyncio
from collections.abc import Awaitable, Callable
from dataclasses import dataclass, field
from typing import Any

from asgiref.sync import async_to_sync, sync_to_async

from cyborg_site.client_address import client_address
from cyborg_site.roles import is_operator, roles_cached
from robot.commands.audit_writer import writer
from robot.link.bus import RobotError, stopping


async def _record(**fields: Any) -> Any:
    if fields["action"] in UNAUDITED_OK:
        return await asyncio.to_thread(_record_here, **fields)
    return await writer.record(**fields)


def _record_here(**fields: Any) -> Any:
    if fields["action"] in UNAUDITED_OK:  # the stop never waits long on the database, however it hangs
        return writer.keep_then_write(**fields, wait_s=AUDIT_WAIT_S)
    return writer.record_here(**fields)


# Run while the audit cannot be written (its entries journaled meanwhile); every other command waits.
UNAUDITED_OK = frozenset({"estop", "estop.release"})
AUDIT_WAIT_S = 0.2  # their entry is on disk at once; written to the database by then, normally


class Forbidden(RobotError):
    status_code = 403
    code = "forbidden"


class InvalidCommand(RobotError):
    status_code = 400
    code = "invalid"

    def __init__(self, message: str, *, field: str | None = None) -> None:
        super().__init__(message)
        self.field = field


class AuditUnavailable(RobotError):
    status_code = 503
    code = "unavailable"


class Busy(RobotError):
    status_code = 409
    code = "busy"


Declaration = Callable[[Any], bool]  # given the checked input: does this run move the robot?


@dataclass(frozen=True)
class Gate:
    """The E-STOP's say on every command: which inputs of an action move the robot (an undeclared
    action cannot be built), and the check that raises ``EstopEngaged`` while the stop is latched."""

    declaration: Callable[[str], Declaration]
    ensure_released: Callable[[], Awaitable[None]]


_gate: list[Gate] = []


def install_gate(gate: Gate) -> None:
    """Installed by the E-STOP at start-up (``robot.apps``); until then no command can be built."""
    _gate[:] = [gate]


def gate() -> Gate:
    if not _gate:
        raise LookupError("the E-STOP's gate is not installed (robot.apps installs it): no command runs without it")
    return _gate[0]


def _unchecked() -> None:
    return None


FORBIDDEN = "Your role may not command the robot (operators and admins can)."


@dataclass
class Command:
    """What to audit (``action``, ``params``), how to check the input and how to send it.

    ``send`` gets what ``check`` returned and returns the outcome for a person; whatever else
    a caller needs back (a goal, a report) it leaves in ``result``. Whether it moves the robot
    is declared by its action in ``robot.estop.rule`` (an undeclared action is refused here).
    """

    action: str
    params: dict[str, Any]
    send: Callable[[Any], Awaitable[str | None]]
    check: Callable[[], Any] = _unchecked
    allowed: Callable[[Any], bool] = is_operator
    refusal: str = FORBIDDEN  # what a person whose role ``allowed`` refuses is told
    result: dict[str, Any] = field(default_factory=dict)
    check_on_loop: bool = False  # ``check`` reads no database: ``arun`` may run it on the event loop
    moves: Declaration = field(init=False)

    def __post_init__(self) -> None:
        self.moves = gate().declaration(self.action)


async def _send(command: Command, checked: Any) -> str:
    """``send``, unless the E-STOP holds back what the command would do, or it could not be
    audited. A command that does not move the robot may stop it further (mode stop, the emotion
    system off): the link lets those of its requests through the latch (``bus.stopping``) and,
    by their content, nothing else."""
    if writer.down and command.action not in UNAUDITED_OK:
        raise AuditUnavailable("The audit log cannot be written (the database is not reachable): commands are "
                               "refused until it can. The E-STOP still works.")
    if command.moves(checked):
        await gate().ensure_released()
        return await command.send(checked) or "ok"
    with stopping():
        return await command.send(checked) or "ok"


def _audit_fields(command: Command, user: Any, source: str) -> dict[str, Any]:
    return {"user": user, "source": source, "action": command.action, "params": command.params,
            "address": client_address.get()}


def _checked(command: Command, user: Any) -> Any:
    """Role check, then ``check``: what ``send`` gets (a refusal or bad input is raised, and audited
    by the face that called it)."""
    if not command.allowed(user):
        raise Forbidden(command.refusal)
    return command.check()


_achecked = sync_to_async(_checked, thread_sensitive=True)


def run_command(command: Command, *, user: Any, source: str) -> str:
    """The synchronous face: one hop onto the event loop, for ``send``."""
    audit = _audit_fields(command, user, source)
    try:
        outcome = async_to_sync(_send)(command, _checked(command, user))
    except RobotError as exc:
        _record_here(**audit, ok=False, outcome=exc.message, error_code=exc.code)
        raise
    _record_here(**audit, ok=True, outcome=outcome)
    return outcome


async def arun(command: Command, *, user: Any, source: str) -> str:
    """The asynchronous face: at most one thread hop before sending, one for the audit entry."""
    audit = _audit_fields(command, user, source)
    try:
        if roles_cached(user) and (command.check is _unchecked or command.check_on_loop):
            checked = _checked(command, user)  # reads only the cached roles: no database on the loop
        else:
            checked = await _achecked(command, user)
        outcome = await _send(command, checked)
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
    command = Command(action, params, lambda _: run(), allowed=allowed, refusal=refusal)
    return await arun(command, user=user, source=source)
