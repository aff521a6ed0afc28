"""The E-STOP latches: zero at once and held, the drive lock freed and blocked, everything
that moves the robot refused (409, "E-STOP engaged by NAME at TIME") on the API and the
websocket until an operator releases it with a confirmation, audited."""

import asyncio
import contextlib
import time

import pytest

from cyborg_site.roles import Role
from robot import interface as ri
from robot.models import AuditEntry
from tests.commands.support import received, until_the_server_hears, wait_ready
from tests.helpers import async_wait_until, receive_until
from tests.teleop.support import drive_socket, is_moving, is_zero, key, settled_steps, twists, wait_twist

pytestmark = pytest.mark.django_db(transaction=True)


@pytest.fixture
def olga(db):
    from tests.conftest import _user

    return _user("olga", Role.OPERATOR)


async def test_a_held_key_never_moves_the_robot_again(link, sim, operator, olga):
    """Otto holds W while Olga presses E-STOP: no non-zero Twist after the stop's zero."""
    from robot.estop.stop import estop_run
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
    from robot.estop.stop import estop_run

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
    from robot.estop.latch import aengage, arelease
    from robot.link.bus import EstopEngaged, apublish
    from robot.teleop.twist import Command, twist

    await aengage(by="someone")
    await async_wait_until(lambda: link.latch.guard.latched, timeout=5, what="the link to read the latch")
    with pytest.raises(EstopEngaged):
        await apublish("cmd_vel", twist(Command(0.3, 0.0)))
    await arelease(by="someone")
    await async_wait_until(lambda: not link.latch.guard.latched, timeout=5, what="the link to read the release")


async def test_the_link_stops_the_robot_when_moving_twists_stop_arriving(link, sim, settings):
    from robot.link.bus import apublish, fresh_press
    from robot.teleop.twist import Command, twist

    with fresh_press():
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


async def test_the_link_holds_back_all_that_moves_but_the_stops_own_steps(link, sim):
    """The last check before the robot, on every publish and service call: a request made
    before the stop and queued, or sent by a mode change still walking, does not get through."""
    from robot.link.bus import EstopEngaged, acall_service, apublish, arequest, stopping
    from robot.navigation.goals import apublish_action, cancel_message, move_base_goal_message

    wait_ready(sim)
    pose = {"header": {"frame_id": "map"}, "pose": {"position": {"x": 1.0, "y": 1.0, "z": 0.0},
                                                    "orientation": {"x": 0, "y": 0, "z": 0, "w": 1}}}
    await arequest("estop")
    for topic, msg in (("register_event", {"data": "behaviour_start"}), ("register_event", {"data": "aborted"}),
                       ("robot_mode", {"data": "demo"}), ("robot_mode", {"data": "stop"}),
                       ("emotional_controller", {"data": "ON"}), ("emotional_controller", {"data": "OFF"}),
                       ("move_base_simple_goal", pose), ("initialpose", {"header": pose["header"], "pose": pose})):
        with pytest.raises(EstopEngaged, match=r"E-STOP engaged: refused until an operator releases it \(/"):
            await apublish(topic, msg)
    with pytest.raises(EstopEngaged):
        await apublish_action("move_base", "goal", move_base_goal_message("g1", 1.0, 1.0, 0.0))
    with pytest.raises(EstopEngaged):
        await acall_service("enable_motors")
    with stopping():  # the stop's own way to suspension passes; entering a mode does not, even from it
        await apublish("register_event", {"data": "aborted"})
        await apublish("emotional_controller", {"data": "OFF"})
        with pytest.raises(EstopEngaged):
            await apublish("register_event", {"data": "demo_start"})
    await apublish_action("move_base", "cancel", cancel_message())  # what stops passes from anyone
    await acall_service("disable_motors")
    await apublish("text_to_speech", {"data": "stopped"})
    await async_wait_until(lambda: received(sim, "text_to_speech"), what="the speech")
    assert [m["data"] for m in received(sim, "register_event")] == ["aborted"]
    assert received(sim, "emotional_controller") == [{"data": "OFF"}]
    assert received(sim, "robot_mode") == received(sim, "initialpose") == received(sim, "move_base_simple_goal") == []
    assert sim.received(ri.action_topic("move_base", "goal")[0]) == []
    assert sim.snapshot()["state"]["motors"] is False


async def test_a_mode_change_under_way_sends_nothing_after_the_estop_answers(link, sim, operator):
    """Behaviour mode requested, the E-STOP pressed 0.05-0.5 s later, 20 times: no event, mode or
    emotion-system message reaches the robot after the stop's answer, and the robot ends in
    suspension with its emotion system off."""
    from robot.commands.modes import achange_mode
    from robot.estop.stop import estop_release, estop_run
    from robot.link.bus import RobotError

    names = [ri.topic(key).name for key in ("register_event", "emotional_controller", "robot_mode")]
    wait_ready(sim)
    for run in range(20):
        await until_the_server_hears(lambda s: s == "suspension", "suspension")
        change = asyncio.ensure_future(achange_mode(user=operator, source="api", mode=ri.Mode.BEHAVIOUR))
        await asyncio.sleep(0.05 + 0.45 * run / 19)
        await estop_run(user=operator, source="page")
        answered = time.time()
        steps = await settled_steps()  # how each ended (on a loaded machine a step may answer late)
        settled = time.time()
        assert all(s["ok"] for s in steps.values()), f"run {run + 1}: {steps}"
        with contextlib.suppress(RobotError):
            await change
        await asyncio.sleep(0.3)  # anything still on its way arrives
        # The stop's own messages may still be on the wire when it answers, or come from a step that
        # answers late on a loaded machine (well under 0.1 s after its steps ended); nothing else may.
        late = [(name, r["msg"], round(r["t"] - answered, 3)) for name in names
                for r in sim.call(lambda n=name: sim.robot.received_with_times(n)) if r["t"] > answered
                if r["t"] > settled + 0.1 or not ri.passes_latch(name, r["msg"], by_the_stop=True)]
        assert late == [], f"run {run + 1}: after the E-STOP's answer the robot got {late}"
        state = sim.snapshot()["state"]
        assert state["smach_state"] == "suspension", f"run {run + 1}: {state}"
        assert received(sim, "emotional_controller")[-1] == {"data": "OFF"}
        await estop_release(user=operator, source="page", confirm=True)
