"""Ask the robot link to do something, from any process: web views, consumers, tasks.

Requests travel over the channel layer to the one link process, so there is exactly one
rosbridge connection however many web processes there are. A request carries a
deadline: if the link gets it too late it is dropped, never fired later.
"""

from __future__ import annotations

import asyncio
import time
import uuid
import weakref
from collections.abc import Iterator
from contextlib import AbstractContextManager, contextmanager
from contextvars import ContextVar
from typing import Any, cast

from asgiref.sync import async_to_sync
from django.conf import settings

from robot import interface as ri
from robot.link import direct
from robot.link.connection import RobotLink
from robot.live import queues
from robot.live.groups import STATUS_KEY, LinkReply, LinkRequest
from robot.live.state import get_store, redis_key, status_view
from robot.supervisor import running, supervise


class RobotError(Exception):
    """A command could not be carried out; ``code`` maps to an HTTP status."""

    status_code = 502
    code = "failed"

    def __init__(self, message: str) -> None:
        super().__init__(message)
        self.message = message


class RobotOffline(RobotError):
    status_code = 503
    code = "offline"


class RobotNotResponding(RobotError):
    """Connected, but the robot has said nothing for a while (robot.link.liveness): it may be hung."""

    status_code = 503
    code = "not_responding"


class RobotTimeout(RobotError):
    status_code = 504
    code = "timeout"


class EstopEngaged(RobotError):
    """Refused because the E-STOP is latched."""

    status_code = 409
    code = "estop"


class ReleaseFirst(RobotError):
    """The link to the robot was lost while a driver moved it: motion waits for a fresh press."""

    status_code = 409
    code = "release_first"


class RobotNotFound(RobotError):
    """The robot has no such thing (a topic rosapi does not know)."""

    status_code = 404
    code = "not_found"


class Throttled(RobotError):
    """Asked again too soon (a reconnect moments after the last)."""

    status_code = 429
    code = "throttled"


_ERRORS: dict[str, type[RobotError]] = {error.code: error for error in RobotError.__subclasses__()}


def _not_responding(request: LinkRequest, *, responding: bool) -> RobotNotResponding | None:
    """A hung robot is sent no command but what stops it (the E-STOP's steps, zero velocity)."""
    if responding or request.get("emergency") or request["op"] not in ("publish", "call_service"):
        return None
    if request.get("topic") == ri.topic("cmd_vel").name and ri.is_zero_twist(request.get("msg") or {}):
        return None
    return RobotNotResponding(f"Robot not responding: nothing heard from {settings.ROSBRIDGE_URL} "
                              f"for {getattr(settings, 'ROBOT_HANG_S', 2.0):g} s; commands wait until it answers")


# The marks of the requests made in this context (``stopping``, ``emergency``, ``fresh_press``).
_marks: ContextVar[tuple[str, ...]] = ContextVar("link_request_marks", default=())


@contextmanager
def _marked(*marks: str) -> Iterator[None]:
    token = _marks.set((*_marks.get(), *marks))
    try:
        yield
    finally:
        _marks.reset(token)


def stopping() -> AbstractContextManager[None]:
    """Requests made inside (and in tasks started inside) are meant to stop the robot (the E-STOP's
    steps, a command that does not move it): the link lets those that stop it through its latch
    (``interface.passes_latch``), and holds back the same requests from anyone else (a mode change
    still walking when the stop came)."""
    return _marked("stopping")


def emergency() -> AbstractContextManager[None]:
    """The E-STOP's own requests: they pass the latch (``stopping``), reach a link that can no
    longer prove its lease because Redis is out of reach, and go by the direct path first."""
    return _marked("stopping", "emergency")


def fresh_press() -> AbstractContextManager[None]:
    """A driver's first move after letting go: it may move a robot whose link was lost while a key
    was held (the held key's own moves wait for one, ``CmdVelGuard.lost``)."""
    return _marked("fresh_press")


def _new_request(op: str, timeout: float, fields: dict[str, Any]) -> LinkRequest:
    return cast(LinkRequest, {
        "type": "link.request", "op": op, "request_id": uuid.uuid4().hex,
        # The link may need most of the timeout for a service call; leave room for the reply.
        "deadline": time.time() + timeout, "timeout": max(0.1, timeout - 0.2), **fields,
        **dict.fromkeys(_marks.get(), True),
    })


async def aping_over_queue(timeout: float) -> bool:
    """Does the link answer over the request queue (never the in-process shortcut)?"""
    try:
        reply = await asyncio.wait_for(_via_queue(_new_request("ping", timeout, {})), timeout)
    except Exception:
        return False
    return bool(reply.get("ok"))


async def arequest(op: str, *, timeout: float | None = None, **fields: Any) -> LinkReply:
    """Send one request to the link and wait for its reply; raise RobotError on failure."""
    timeout = timeout or settings.ROBOT_REQUEST_TIMEOUT_S
    request = _new_request(op, timeout, fields)
    hosted = running(RobotLink)
    try:
        # asyncio.timeout, not wait_for: wait_for runs the request as a task of its own, a loop
        # turn later (a command would wait for it before anything is sent).
        async with asyncio.timeout(timeout):
            if hosted is not None and hosted.dial.loop is not None and not hosted.dial.loop.is_closed():
                if refusal := _not_responding(request, responding=hosted.dial.responding or not hosted.connected):
                    raise refusal
                reply = await _in_process(hosted, request)
            else:
                reply = await _to_link_process(request, timeout)
    except TimeoutError:
        raise RobotTimeout(f"Command path down? The robot link did not answer in {timeout:g} s") from None
    if not reply.get("ok"):
        raise _ERRORS.get(reply.get("error_code", ""), RobotError)(reply.get("error", "The robot refused the command"))
    return reply


async def _to_link_process(request: LinkRequest, timeout: float) -> LinkReply:
    if request.get("emergency") and direct.enabled():
        try:
            return await direct.ask(request, timeout)
        except direct.Unreachable:
            pass  # no link listens there (an older one, or none yet): the usual way
    # These reach a link whose robot is away: leases of watched topics (it subscribes on return), and
    # acknowledging an alert (the robot being offline is one).
    if request["op"] not in ("reconnect", "topics_watch", "alert_ack"):
        view = status_view((await get_store().aget_many([STATUS_KEY])).get(STATUS_KEY))
        if not (view["robot_connected"] or view.get("connecting")):
            raise RobotOffline(f"Robot offline: no connection to {settings.ROSBRIDGE_URL}")
        if refusal := _not_responding(request, responding=view["responding"]):
            raise refusal
    return await _via_queue(request)


async def _in_process(hosted: RobotLink, request: LinkRequest) -> LinkReply:
    """The link lives in this process (embedded default): no queue hop."""
    if asyncio.get_running_loop() is hosted.dial.loop:
        return await hosted.requests.execute(request)
    assert hosted.dial.loop is not None  # set when the link starts, before it is hosted
    future = asyncio.run_coroutine_threadsafe(hosted.requests.execute(request), hosted.dial.loop)
    return await asyncio.wrap_future(future)


class _Replies:
    """Where the link's replies come back to this process: a queue of its own (robot.live.queues),
    read by one supervised task that hands each reply to the request waiting for it."""

    def __init__(self) -> None:
        self.address = redis_key(f"link-replies:{uuid.uuid4().hex}")
        self.waiting: dict[str, asyncio.Future] = {}
        self._task: asyncio.Task | None = None

    def reply_to(self) -> str:
        if self._task is None or self._task.done():
            self._task = supervise(f"bus.replies.{self.address[-8:]}", self._receive)
        return self.address

    async def _receive(self) -> None:
        while True:
            reply = await queues.pop(self.address)
            future = self.waiting.pop((reply or {}).get("request_id", ""), None)
            if future is not None and not future.done():
                future.set_result(reply)


_replies: weakref.WeakKeyDictionary[asyncio.AbstractEventLoop, _Replies] = weakref.WeakKeyDictionary()


async def _via_queue(request: LinkRequest) -> LinkReply:
    """Send a request to the link's queue and wait for its reply."""
    loop = asyncio.get_running_loop()
    replies = _replies.get(loop)
    if replies is None:
        replies = _replies[loop] = _Replies()
    request["reply_to"] = replies.reply_to()
    future = replies.waiting[request["request_id"]] = loop.create_future()
    try:
        await queues.push(queues.requests_key(), dict(request))
        return await future
    finally:
        replies.waiting.pop(request["request_id"], None)


async def apublish(key: str, msg: dict[str, Any]) -> None:
    """Publish ``msg`` on the registry topic ``key`` (validate it before calling)."""
    t = ri.topic(key)
    await arequest("publish", topic=t.name, msg_type=t.type, msg=msg)


async def acall_service(key: str, args: dict[str, Any] | None = None, *, timeout: float | None = None) -> Any:
    s = ri.service(key)
    reply = await arequest("call_service", service=s.name, service_type=s.type, args=args or {}, timeout=timeout)
    return reply.get("values")


publish = async_to_sync(apublish)
call_service = async_to_sync(acall_service)
request = async_to_sync(arequest)
