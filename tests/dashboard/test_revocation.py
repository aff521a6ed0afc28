"""Revoking access reaches open sockets at once: an operator demoted, deactivated or logged out
stops driving (zero, the drive lock given back) and their drive and audio sockets close, while
the same person's other sessions and other people's sockets stay."""

from __future__ import annotations

import asyncio

import pytest
from channels.db import database_sync_to_async
from django.contrib.auth.models import Group
from django.test import Client

from cyborg_site.roles import Role
from tests.helpers import ws_communicator
from tests.teleop.support import is_moving, is_zero, key, twists, wait_twist

pytestmark = pytest.mark.django_db(transaction=True)


def _session_of(user) -> tuple[Client, bytes]:
    client = Client()
    client.force_login(user)
    return client, f"sessionid={client.cookies['sessionid'].value}".encode()


async def _socket(path: str, cookie: bytes):
    communicator = ws_communicator(None, path)
    communicator.scope["headers"] = [*communicator.scope["headers"], (b"cookie", cookie)]
    connected, _ = await communicator.connect(timeout=10)
    assert connected
    return communicator


async def _closed_with(communicator, code: int, within_s: float = 1.0) -> None:
    """The server closes the socket within ``within_s`` (frames before the close are skipped)."""
    async with asyncio.timeout(within_s):
        while True:
            message = await communicator.output_queue.get()
            if message["type"] == "websocket.close":
                assert message.get("code") == code, message
                return


async def _drive(cookie: bytes, sim):
    ws = await _socket("/ws/teleop/", cookie)
    await ws.receive_json_from(timeout=5)  # the lock frame
    await ws.send_json_to(key(1.0))
    await wait_twist(sim, is_moving)
    return ws


@pytest.mark.parametrize("change", ["demoted", "group emptied", "deactivated", "password"])
async def test_an_access_change_stops_the_driver_and_closes_their_sockets(link, sim, operator, change):
    _, cookie = await database_sync_to_async(_session_of)(operator)
    drive = await _drive(cookie, sim)
    audio = await _socket("/ws/audio/", cookie)

    def revoke() -> None:
        if change == "demoted":
            operator.groups.set([Group.objects.get(name=Role.VIEWER)])
        elif change == "group emptied":  # from the group's side: Admin → Groups, or a script
            Group.objects.get(name=Role.OPERATOR).user_set.clear()
        elif change == "deactivated":
            operator.is_active = False
            operator.save()
        else:
            operator.set_password("a whole new one")
            operator.save()

    before = len(await twists(sim))
    await database_sync_to_async(revoke)()
    code = 4403 if change in ("demoted", "group emptied") else 4401
    await _closed_with(drive, code)
    await _closed_with(audio, code)
    await wait_twist(sim, is_zero, after=before, what="the driver's zero")
    # (Under load the link's own deadman may send a zero first, and the driver's next tick move
    # it again before the revocation: what counts is that the last word is a stop.)
    settled = len(await twists(sim))
    await asyncio.sleep(0.3)
    sent = await twists(sim)
    assert is_zero(sent[-1]), "the robot's last command after the revocation was not a stop"
    assert not any(is_moving(t) for t in sent[settled:]), "the robot moved after the revocation"
    from robot.teleop.lock import get_lock

    assert await get_lock().holder() is None


async def test_a_logout_closes_that_sessions_sockets_only(link, sim, operator, admin_user):
    client, cookie = await database_sync_to_async(_session_of)(operator)
    _, other_cookie = await database_sync_to_async(_session_of)(operator)  # the same person elsewhere
    _, admins = await database_sync_to_async(_session_of)(admin_user)
    drive = await _drive(cookie, sim)
    elsewhere = await _socket("/ws/audio/", other_cookie)
    admin = await _socket("/ws/audio/", admins)
    before = len(await twists(sim))
    await database_sync_to_async(client.post)("/accounts/logout/")
    await _closed_with(drive, 4401)
    await wait_twist(sim, is_zero, after=before, what="the driver's zero")
    for still_open in (elsewhere, admin):
        await still_open.send_to(text_data='{"type": "nonsense"}')
        assert (await still_open.receive_json_from(timeout=5))["type"] in ("hello", "error")
        await still_open.disconnect()


async def test_an_admin_ends_a_persons_sessions_and_tokens_at_once(link, sim, operator, admin_user):
    """Admin → Users → "End their sessions and API tokens now": every session of that person ends
    (their open sockets close as after a logout), their tokens stop working; the admin's stay."""
    from rest_framework.authtoken.models import Token

    from robot.models import AuditEntry

    phone, cookie = await database_sync_to_async(_session_of)(operator)
    laptop, other_cookie = await database_sync_to_async(_session_of)(operator)
    admin, _ = await database_sync_to_async(_session_of)(admin_user)
    token = await database_sync_to_async(Token.objects.create)(user=operator)
    drive = await _drive(cookie, sim)
    audio = await _socket("/ws/audio/", other_cookie)
    before = len(await twists(sim))
    answer = await database_sync_to_async(admin.post)(
        "/admin/auth/user/", {"action": "end_sessions", "_selected_action": [operator.pk]}, follow=True)
    assert "2 sessions and 1 API tokens of otto ended." in answer.content.decode()
    await _closed_with(drive, 4401)
    await _closed_with(audio, 4401)
    await wait_twist(sim, is_zero, after=before, what="the driver's zero")
    for client in (phone, laptop):
        assert (await database_sync_to_async(client.get)("/")).status_code == 302
    assert (await database_sync_to_async(Client().get)(
        "/api/robot/state/", HTTP_AUTHORIZATION=f"Token {token.key}")).status_code == 401
    assert (await database_sync_to_async(admin.get)("/")).status_code == 200
    entry = await database_sync_to_async(AuditEntry.objects.filter(action="account.sessions_ended").get)()
    assert (entry.username, entry.params, entry.outcome) == ("ada", {"username": "otto"},
                                                             "2 sessions and 1 API tokens ended")
