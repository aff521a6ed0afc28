"""/ws/teleop/ against the simulator: input → Twist within limits, zero on release, hide,
disconnect and silence, one driver at a time, viewers and anonymous refused."""

import asyncio
import json

import pytest
from django.contrib.auth.models import AnonymousUser

from robot.models import AuditEntry
from tests.helpers import DEADLINE_S, ws_communicator
from tests.teleop.support import (
    drive_socket,
    error_frame,
    is_moving,
    is_zero,
    key,
    lock_frame,
    twists,
    wait_twist,
)

pytestmark = pytest.mark.django_db(transaction=True)


async def test_it_publishes_the_clamped_twist_at_the_simulator(link, sim, operator, settings):
    ws = await drive_socket(operator)
    await ws.send_json_to(key(1.0, -1.0, max_linear=5.0, max_angular=0.4))
    twist = await wait_twist(sim, is_moving)
    assert twist["linear"]["x"] == settings.TELEOP_MAX_LINEAR  # the slider cannot exceed the server limit
    assert twist["angular"]["z"] == pytest.approx(-0.4)
    assert (await lock_frame(ws, lambda f: f["you"]))["holder"] == "otto"
    await ws.disconnect()


async def test_it_keeps_publishing_at_a_fixed_rate_while_input_is_held(link, sim, operator):
    ws = await drive_socket(operator)
    for _ in range(8):  # the page repeats unchanged input every 50 ms
        await ws.send_json_to(key(0.5))
        await asyncio.sleep(0.05)
    moving = [t for t in await twists(sim) if is_moving(t)]
    # One immediate publish, then the 10 Hz loop; never one per repeated input.
    assert 2 <= len(moving) < 8
    await ws.disconnect()


async def test_it_publishes_zero_at_once_on_release(link, sim, operator):
    ws = await drive_socket(operator)
    await ws.send_json_to(key(1.0))
    await wait_twist(sim, is_moving)
    await ws.send_json_to({"type": "release"})
    seen = len(await twists(sim))
    await wait_twist(sim, is_zero)
    await asyncio.sleep(0.3)  # the loop has stopped: nothing but the zero follows
    assert all(is_zero(t) for t in (await twists(sim))[seen - 1:][1:])
    await ws.disconnect()


async def test_it_publishes_zero_when_the_page_is_hidden(link, sim, operator):
    ws = await drive_socket(operator)
    await ws.send_json_to(key(0.0, 1.0))
    await wait_twist(sim, is_moving)
    await ws.send_json_to({"type": "hidden"})
    await wait_twist(sim, is_zero)
    await ws.disconnect()


async def test_it_publishes_zero_when_the_socket_disconnects(link, sim, operator):
    ws = await drive_socket(operator)
    await ws.send_json_to(key(1.0))
    await wait_twist(sim, is_moving)
    await ws.disconnect()
    await wait_twist(sim, is_zero)
    assert await AuditEntry.objects.filter(action="teleop.unlock", params__reason="disconnect").aexists()


async def test_it_stops_the_robot_when_input_goes_silent(link, sim, operator, settings):
    settings.TELEOP_DEADMAN_S = 0.3
    ws = await drive_socket(operator)
    await ws.send_json_to(key(1.0))
    await wait_twist(sim, is_moving)
    frame = await ws.receive_json_from(timeout=DEADLINE_S)
    while frame.get("reason") != "deadman":
        frame = await ws.receive_json_from(timeout=DEADLINE_S)
    assert frame == {"type": "commanded", "linear": 0.0, "angular": 0.0, "reason": "deadman"}
    await wait_twist(sim, is_zero)
    assert await AuditEntry.objects.filter(action="teleop.deadman").aexists()
    await ws.disconnect()


async def test_it_refuses_a_second_operator_while_one_drives(link, sim, operator, admin_user, django_user_model):
    from cyborg_site.roles import Role
    from dashboard.accounts import create_user

    olga = await asyncio.to_thread(lambda: create_user("olga", Role.OPERATOR, password="x" * 12)[0])
    otto_ws, olga_ws = await drive_socket(operator), await drive_socket(olga)
    await otto_ws.send_json_to(key(1.0))
    await wait_twist(sim, is_moving)
    assert (await lock_frame(olga_ws, lambda f: f["holder"] == "otto"))["you"] is False

    await olga_ws.send_json_to(key(-1.0))
    assert (await error_frame(olga_ws))["message"] == "otto is driving."
    await olga_ws.send_json_to({"type": "acquire"})
    assert (await error_frame(olga_ws))["code"] == "busy"
    await asyncio.sleep(0.2)
    assert not any(t["linear"]["x"] < 0 for t in await twists(sim))

    await otto_ws.disconnect()  # the lock frees with the driver's socket
    await lock_frame(olga_ws, lambda f: f["holder"] is None)
    await olga_ws.send_json_to(key(-1.0))
    await wait_twist(sim, lambda t: t["linear"]["x"] < 0)
    await olga_ws.disconnect()


async def test_it_lets_an_admin_take_over_and_stops_the_previous_driver(link, sim, operator, admin_user):
    otto_ws, ada_ws = await drive_socket(operator), await drive_socket(admin_user)
    await otto_ws.send_json_to(key(1.0))
    await wait_twist(sim, is_moving)

    await otto_ws.send_json_to({"type": "takeover"})  # operators may not
    refused = await error_frame(otto_ws)
    assert refused["code"] == "forbidden" and "Only admins" in str(refused), refused

    await ada_ws.send_json_to({"type": "takeover"})
    assert (await lock_frame(otto_ws, lambda f: f["holder"] == "ada"))["you"] is False
    await lock_frame(ada_ws, lambda f: f["you"])
    count = len(await twists(sim))
    await wait_twist(sim, is_zero, after=count - 1)
    await asyncio.sleep(0.3)
    assert all(is_zero(t) for t in (await twists(sim))[count:])  # otto's loop has stopped
    await otto_ws.send_json_to(key(1.0))
    assert (await error_frame(otto_ws))["message"] == "ada is driving."
    assert await AuditEntry.objects.filter(action="teleop.takeover", username="ada", ok=True).aexists()
    await otto_ws.disconnect()
    await ada_ws.disconnect()


async def test_it_shows_viewers_who_drives_but_refuses_their_input(link, sim, viewer, operator):
    otto_ws = await drive_socket(operator)
    await otto_ws.send_json_to({"type": "acquire"})
    await lock_frame(otto_ws, lambda f: f["you"])

    vera_ws = ws_communicator(viewer, "/ws/teleop/")
    assert (await vera_ws.connect())[0]
    assert await vera_ws.receive_json_from(timeout=5) == {"type": "lock", "holder": "otto", "you": False}
    for frame in (key(1.0), {"type": "acquire"}):
        await vera_ws.send_json_to(frame)
        assert (await error_frame(vera_ws))["code"] == "forbidden"
    await asyncio.sleep(0.2)
    assert await twists(sim) == []
    await vera_ws.disconnect()
    await otto_ws.disconnect()


async def test_it_refuses_anonymous_sockets_before_accepting(db):
    ws = ws_communicator(AnonymousUser(), "/ws/teleop/")
    connected, code = await ws.connect()
    assert connected is False and code == 4401


@pytest.mark.parametrize("text", [
    json.dumps(key("fast")), '{"type": "input", "linear": NaN, "angular": 0}', json.dumps(key(1e400)),
    json.dumps(key(True)), "not json", json.dumps(["input"]), json.dumps({"type": "warp"}),
])
async def test_it_answers_bad_frames_with_an_error_and_sends_nothing(link, sim, operator, text):
    ws = await drive_socket(operator)
    await ws.send_to(text_data=text)
    assert (await error_frame(ws))["code"] == "invalid"
    await ws.send_json_to(key(0.2))  # the socket still works
    await wait_twist(sim, is_moving)
    # Only the valid key's Twist (repeated if the loop's next tick came meanwhile): none from the bad frame.
    sent = await twists(sim)
    assert all(twist == sent[0] for twist in sent), sent
    await ws.disconnect()


async def test_it_frees_the_lock_on_unlock_and_audits_it(link, sim, operator, viewer):
    otto_ws, vera_ws = await drive_socket(operator), await drive_socket(viewer)
    await otto_ws.send_json_to(key(1.0))
    await lock_frame(vera_ws, lambda f: f["holder"] == "otto")
    await otto_ws.send_json_to({"type": "unlock"})
    await lock_frame(vera_ws, lambda f: f["holder"] is None)
    await wait_twist(sim, is_zero)
    actions = [a async for a in AuditEntry.objects.order_by("id").values_list("action", flat=True)]
    assert actions == ["teleop.lock", "teleop.unlock"]  # lock events, never a Twist
    await otto_ws.disconnect()
    await vera_ws.disconnect()


async def test_it_tells_every_page_when_an_idle_drivers_lock_times_out(link, sim, operator, viewer, settings):
    settings.TELEOP_LOCK_TTL_S = 1.0
    from robot.teleop.lock import reset_lock

    reset_lock()
    otto_ws, vera_ws = await drive_socket(operator), await drive_socket(viewer)
    await otto_ws.send_json_to({"type": "acquire"})
    await lock_frame(vera_ws, lambda f: f["holder"] == "otto")
    await lock_frame(vera_ws, lambda f: f["holder"] is None)
    assert await AuditEntry.objects.filter(action="teleop.unlock", params__reason="timeout").aexists()
    await otto_ws.disconnect()
    await vera_ws.disconnect()


async def test_its_audit_entries_carry_the_clients_address(link, sim, operator):
    ws = ws_communicator(operator, "/ws/teleop/")
    ws.scope["client"] = ("10.1.2.3", 50123)  # what Daphne takes from the proxy
    assert (await ws.connect())[0]
    await ws.receive_json_from(timeout=5)
    await ws.send_json_to({"type": "acquire"})
    for _ in range(250):
        if await AuditEntry.objects.filter(action="teleop.lock").aexists():
            break
        await asyncio.sleep(0.02)
    entry = await AuditEntry.objects.aget(action="teleop.lock")
    assert (entry.username, entry.address) == ("otto", "10.1.2.3")
    await ws.disconnect()
