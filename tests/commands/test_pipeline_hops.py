"""How often a command crosses between a thread and the event loop: once on each face."""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

import pytest
from channels.db import database_sync_to_async
from django.contrib.auth import get_user_model

from cyborg_site.roles import is_operator, roles_cached
from robot.commands.pipeline import Command, Forbidden, arun
from robot.models import AuditEntry

pytestmark = pytest.mark.django_db(transaction=True)


def _counting(real: Callable[..., Any], calls: list[str]) -> Callable[..., Any]:
    def wrap(fn: Any, *args: Any, **kwargs: Any) -> Any:
        calls.append(getattr(fn, "__name__", repr(fn)))
        return real(fn, *args, **kwargs)

    return wrap


def test_an_estop_from_the_api_crosses_to_the_event_loop_once(operator_api, monkeypatch):
    from robot.commands import pipeline
    from robot.estop import views as estop_views

    calls: list[str] = []
    monkeypatch.setattr(pipeline, "async_to_sync", _counting(pipeline.async_to_sync, calls))
    monkeypatch.setattr(estop_views, "async_to_sync", _counting(estop_views.async_to_sync, calls))
    response = operator_api.post("/api/robot/estop/")  # no robot: every robot step fails, the rest runs
    assert response.status_code == 502 and response.json()["latch"]["latched"] is True
    assert calls == ["_send"]
    assert AuditEntry.objects.get(action="estop").error_code == "partial"

    calls.clear()
    response = operator_api.post("/api/robot/estop/release/", {"confirm": True}, format="json")
    assert response.status_code == 200 and response.json()["latched"] is False
    assert calls == ["_send"]


def _recorder(seen: dict[str, int], name: str, result: Any) -> Callable[..., Any]:
    def record(*args: Any) -> Any:
        seen[name] = threading.get_ident()
        return result(*args) if callable(result) else result

    return record


async def test_a_socket_users_command_runs_its_role_check_on_the_loop(operator, viewer):
    await database_sync_to_async(is_operator)(operator)  # what a consumer does when the socket connects
    await database_sync_to_async(is_operator)(viewer)
    assert roles_cached(operator) and roles_cached(viewer)
    loop_thread = threading.get_ident()
    seen: dict[str, int] = {}

    async def send(_: Any) -> str:
        seen["send"] = threading.get_ident()
        return "sent"

    command = Command("speech", {}, send, allowed=_recorder(seen, "allowed", is_operator))
    assert await arun(command, user=operator, source="websocket") == "sent"
    assert seen == {"allowed": loop_thread, "send": loop_thread}
    entry = await AuditEntry.objects.aget(action="speech")
    assert entry.ok and entry.outcome == "sent" and entry.username == operator.username

    seen.clear()
    refused = Command("emotion", {}, send, allowed=_recorder(seen, "allowed", is_operator))
    with pytest.raises(Forbidden):
        await arun(refused, user=viewer, source="websocket")
    assert seen == {"allowed": loop_thread}
    assert (await AuditEntry.objects.aget(action="emotion")).error_code == "forbidden"


async def test_an_uncached_user_or_a_check_costs_one_thread_hop_for_both(operator):
    fresh = await get_user_model().objects.aget(pk=operator.pk)  # roles not read yet
    assert not roles_cached(fresh)
    loop_thread = threading.get_ident()
    seen: dict[str, int] = {}

    async def send(checked: Any) -> str:
        seen["send"] = threading.get_ident()
        return f"sent {checked}"

    command = Command("dome", {}, send, check=_recorder(seen, "check", 7),
                      allowed=_recorder(seen, "allowed", is_operator))
    assert await arun(command, user=fresh, source="task") == "sent 7"
    assert seen["allowed"] == seen["check"] != loop_thread
    assert seen["send"] == loop_thread
