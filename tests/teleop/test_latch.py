"""The E-STOP latches: zero at once and held, the drive lock freed and blocked, everything
that moves the robot refused (409, "E-STOP engaged by NAME at TIME") on the API and the
websocket until an operator releases it with a confirmation, audited."""

import asyncio

import pytest

from cyborg_site.roles import Role
from robot import interface as ri
from robot.models import AuditEntry
from tests.helpers import async_wait_until, receive_until
from tests.teleop.support import drive_socket, is_moving, is_zero, key, twists, wait_twist

pytestmark = pytest.mark.django_db(transaction=True)


@pytest.fixture
def olga(db):
    from tests.conftest import _user

    return _user("olga", Role.OPERATOR)


async def test_a_held_key_never_moves_the_robot_again(link, sim, operator, olga):
    """Otto holds W while Olga presses E-STOP: no non-zero Twist after the stop's zero."""
    from robot.teleop.estop import estop_run
    from robot.teleop.lock import get_lock

    ws = await drive_socket(operator)
    await ws.send_json_to(key(1.0))
    await wait_twist(sim, is_moving)

    async def keep_holding_w() -> None:
        while True:
            await ws.send_json_to(key(1.0))
            await asyncio.sleep(0.05)

    holding = asyncio.ensure_future(keep_holding_w())
    try:
        before = len(await twists(sim))
        report = await estop_run(user=olga, source="page")
        assert report.ok, report.summary()
        estop = await receive_until(ws, lambda f: f["type"] == "estop")
        assert estop["latched"] and estop["message"].startswith("E-STOP engaged by olga at ")
        refused = await receive_until(ws, lambda f: f["type"] == "error" and f["code"] == "estop")
        assert refused["message"].startswith("E-STOP engaged by olga at ")
        await asyncio.sleep(1.5)  # a held key for longer than the hold: still nothing moves
    finally:
        holding.cancel()
    after = (await twists(sim))[before:]
    first_zero = next(i for i, t in enumerate(after) if is_zero(t))
    assert not any(is_moving(t) for t in after[first_zero:]), after
    assert sum(1 for t in after if is_zero(t)) >= 5  # zero repeated through the hold
    assert await get_lock().holder() is None
    # The refusal was audited once, not once per key repeat.
    assert await AuditEntry.objects.filter(action="teleop.input", ok=False).acount() == 1
    await ws.disconnect()


async def test_lock_requests_and_takeovers_are_refused_while_latched(link, sim, operator, admin_user):
    from robot.teleop.estop import estop_run

    await estop_run(user=operator, source="page")
    for user, request in ((operator, {"type": "acquire"}), (admin_user, {"type": "takeover"}),
                          (operator, key(0.5))):
        ws = await drive_socket(user)
        assert (await receive_until(ws, lambda f: f["type"] == "estop"))["latched"] is True
        await ws.send_json_to(request)
        error = await receive_until(ws, lambda f: f["type"] == "error")
        assert error["code"] == "estop" and "E-STOP engaged by otto at " in error["message"]
        await ws.disconnect()
    assert not any(is_moving(t) for t in await twists(sim))


async def test_the_link_refuses_motion_and_holds_zero_while_latched(link, sim, settings):
    from robot.link.bus import EstopEngaged, apublish, arequest
    from robot.teleop.twist import Command, twist

    await arequest("estop")
    with pytest.raises(EstopEngaged):
        await apublish("cmd_vel", twist(Command(0.3, 0.0)))
    await apublish("cmd_vel", twist(Command()))  # zero is always allowed
    await asyncio.sleep(settings.ESTOP_HOLD_S + 0.2)
    held = await twists(sim)  # nothing moved before the stop in this test
    assert len(held) >= settings.ESTOP_HOLD_S * settings.TELEOP_RATE_HZ * 0.6 and all(is_zero(t) for t in held)
    await arequest("estop_release")
    await apublish("cmd_vel", twist(Command(0.3, 0.0)))
    await wait_twist(sim, is_moving)


async def test_the_link_follows_a_latch_set_in_the_shared_store(link, sim):
    """A press while the link could not be told (another process, a dead command path)."""
    from robot.link.bus import EstopEngaged, apublish
    from robot.teleop.latch import aengage, arelease
    from robot.teleop.twist import Command, twist

    await aengage(by="someone")
    await async_wait_until(lambda: link.guard.latched, timeout=5, what="the link to read the latch")
    with pytest.raises(EstopEngaged):
        await apublish("cmd_vel", twist(Command(0.3, 0.0)))
    await arelease(by="someone")
    await async_wait_until(lambda: not link.guard.latched, timeout=5, what="the link to read the release")


async def test_the_link_stops_the_robot_when_moving_twists_stop_arriving(link, sim, settings):
    from robot.link.bus import apublish
    from robot.teleop.twist import Command, twist

    await apublish("cmd_vel", twist(Command(0.3, 0.0)))
    count = len(await twists(sim))
    zero = await wait_twist(sim, is_zero, after=count, timeout=settings.TELEOP_LINK_DEADMAN_S + 1)
    assert zero is not None


def test_the_api_refuses_everything_that_moves_while_latched(operator_api, admin_api, link_thread, sim):
    from robot.models import Location
    from tests.commands.support import wait_ready

    wait_ready(sim)
    Location.objects.create(name="dock", x=1.0, y=1.0, yaw=0.0)
    assert operator_api.post("/api/robot/estop/").status_code == 200
    events = len(sim.received(ri.topic("register_event").name))
    refused = {
        "/api/robot/motors/": {"enabled": True},
        "/api/robot/mode/": {"mode": "manual"},
        "/api/robot/event/": {"event": "manual_start"},
        "/api/navigation/goal/": {"x": 1.0, "y": 1.0},
        "/api/navigation/initial-pose/": {"x": 1.0, "y": 1.0},
        "/api/locations/dock/go/": {},
    }
    for path, body in refused.items():
        response = operator_api.post(path, body, format="json")
        assert response.status_code == 409, (path, response.content)
        assert response.json()["code"] == "estop"
        assert response.json()["detail"].startswith("E-STOP engaged by otto at "), response.json()
    assert len(sim.received(ri.topic("register_event").name)) == events
    assert not any(is_moving(t) for t in sim.received(ri.topic("cmd_vel").name))
    assert not sim.snapshot()["state"]["motors"]
    # Stopping further is never refused.
    assert operator_api.post("/api/robot/motors/", {"enabled": False}, format="json").status_code == 200
    assert operator_api.post("/api/robot/mode/", {"mode": "stop"}, format="json").status_code == 200


def test_only_a_confirmed_release_by_an_operator_clears_it(operator_api, viewer_api, link_thread, sim):
    from tests.commands.support import wait_ready

    wait_ready(sim)
    operator_api.post("/api/robot/estop/")
    assert viewer_api.post("/api/robot/estop/release/", {"confirm": True}, format="json").status_code == 403
    unconfirmed = operator_api.post("/api/robot/estop/release/", {}, format="json")
    assert unconfirmed.status_code == 400 and unconfirmed.json()["field"] == "confirm"
    assert operator_api.get("/api/robot/estop/").json()["latched"] is True
    assert operator_api.post("/api/robot/motors/", {"enabled": True}, format="json").status_code == 409

    released = operator_api.post("/api/robot/estop/release/", {"confirm": True}, format="json")
    assert released.status_code == 200, released.content
    assert released.json()["latched"] is False and released.json()["released_by"] == "otto"
    entry = AuditEntry.objects.get(action="estop.release", ok=True)
    assert entry.username == "otto" and "E-STOP engaged by otto" in entry.outcome
    assert operator_api.post("/api/robot/motors/", {"enabled": True}, format="json").status_code == 200
