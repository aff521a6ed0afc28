"""The emergency stop: all four actions reach the simulator, each is reported, it is
audited, every step is tried when the robot is offline, viewers are refused."""

import asyncio

import pytest
from asgiref.sync import async_to_sync

from robot import interface as ri
from robot.models import AuditEntry
from tests.commands.support import wait_ready, wait_state
from tests.conftest import EITHER_ROS
from tests.teleop.support import (
    STILL_TRYING,
    drive_socket,
    is_moving,
    is_zero,
    key,
    lock_frame,
    settled_steps,
    twists,
    wait_twist,
)

# The API runs the async service from a sync view: database_sync_to_async closes the
# connection a plain test transaction lives on (PostgreSQL), so these tests commit.
pytestmark = pytest.mark.django_db(transaction=True)
STEPS = ["latch", "zero_velocity", "drive_lock", "talk", "cancel_navigation", "disable_motors", "mode_stop"]
STAGE_GOAL = {"header": {"frame_id": ri.MAP_FRAME},
              "pose": {"position": {"x": 6.5, "y": -1.0, "z": 0.0}, "orientation": {"x": 0, "y": 0, "z": 0, "w": 1}}}


@pytest.fixture
def busy_robot(sim, link_thread):
    """The simulated robot in manual mode, driving to a goal, motors on."""
    from robot.link.bus import publish

    wait_ready(sim)
    sim.call(lambda: sim.robot.controller.fire(ri.Event.MANUAL_START))
    publish("move_base_simple_goal", STAGE_GOAL)
    wait_state(sim, lambda s: s["navigating"] and s["smach_state"] == "manual" and s["v"] != 0, "goal under way")
    return sim


@EITHER_ROS
def test_it_does_all_four_things_and_audits_it(operator_api, busy_robot):
    sim = busy_robot
    response = operator_api.post("/api/robot/estop/")
    body = response.json()
    assert [s["step"] for s in body["steps"]] == STEPS
    # Every step done by the answer, or (a loaded machine) done since and kept with the latch.
    assert all(s["ok"] or s["detail"].endswith(STILL_TRYING) for s in body["steps"]), body["steps"]
    assert response.status_code == (200 if body["ok"] else 502)
    assert all(s["ok"] for s in async_to_sync(settled_steps)().values())

    assert is_zero(sim.received(ri.topic("cmd_vel").name)[-1])
    if sim.robot.ros == ri.ROS1:  # on ROS 2 the cancel is a call of the hidden cancel_goal service
        assert {"stamp": {"secs": 0, "nsecs": 0}, "id": ""} in sim.received(ri.action("move_base").name + "/cancel")
    state = wait_state(sim, lambda s: not s["navigating"] and not s["motors"] and s["smach_state"] == "suspension",
                       "navigation cancelled, motors off, suspended")
    assert state["v"] == 0 and state["w"] == 0 and state["emotion_system"] is False
    entry = AuditEntry.objects.get(action="estop")
    assert entry.ok is body["ok"] and entry.username == "otto" and entry.source == "api"
    assert all(step in entry.outcome for step in STEPS)


def test_it_tries_every_step_and_reports_each_when_the_robot_is_offline(operator_api, db):
    response = operator_api.post("/api/robot/estop/")
    assert response.status_code == 502
    body = response.json()
    assert body["ok"] is False and body["code"] == "partial"
    assert [s["step"] for s in body["steps"]] == STEPS
    robot_steps = [s for s in body["steps"] if s["step"] not in ("latch", "drive_lock", "talk")]
    assert not any(s["ok"] for s in robot_steps)
    assert all("offline" in s["detail"].lower() for s in robot_steps), body["steps"]
    entry = AuditEntry.objects.get(action="estop")
    assert entry.ok is False and entry.error_code == "partial"
    # The latch holds all the same, and every page can see which steps failed.
    latch = operator_api.get("/api/robot/estop/").json()
    assert latch["latched"] is True and latch["by"] == "otto"
    assert {s["step"] for s in latch["steps"] if not s["ok"]} == {s["step"] for s in robot_steps}
    refused = operator_api.post("/api/robot/motors/", {"enabled": True}, format="json")
    assert refused.status_code == 409 and refused.json()["detail"].startswith("E-STOP engaged by otto at ")


def test_it_refuses_viewers_and_anonymous_callers(viewer_api, anon_api, sim, link_thread):
    assert viewer_api.post("/api/robot/estop/").status_code == 403
    assert anon_api.post("/api/robot/estop/").status_code in (401, 403)
    assert sim.received(ri.topic("cmd_vel").name) == []
    assert sim.snapshot()["state"]["motors"] is True
    assert AuditEntry.objects.get(action="estop").ok is False


def test_it_shows_the_button_to_operators_only_on_every_page(client, operator, viewer):
    client.force_login(operator)
    for path in ("/", "/drive/"):
        assert 'id="estop-btn"' in client.get(path).content.decode()
    client.force_login(viewer)
    assert 'id="estop-btn"' not in client.get("/").content.decode()


async def test_it_ends_the_active_teleop_session_and_frees_the_lock(link, sim, operator):
    from robot.estop.stop import estop_run
    from robot.teleop.lock import get_lock

    ws = await drive_socket(operator)
    await ws.send_json_to(key(1.0))
    await wait_twist(sim, is_moving)
    report = await estop_run(user=operator, source="page")
    assert report.steps[2].ok and "otto stopped driving" in report.steps[2].detail
    await lock_frame(ws, lambda f: f["holder"] is None and not f["you"])
    assert await get_lock().holder() is None
    count = len(await twists(sim))
    await wait_twist(sim, is_zero, after=count - 1)
    await asyncio.sleep(0.3)
    assert all(is_zero(t) for t in (await twists(sim))[count - 1:])  # the driver's loop stopped
    await ws.disconnect()
