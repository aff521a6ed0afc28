"""Alerts raised where the link runs, from a real simulator over rosbridge: shown to every live
socket, kept in the database, taken over with their start by the next raiser, acknowledged."""

import asyncio
import threading
import uuid

import pytest
from asgiref.sync import sync_to_async
from django.db import OperationalError

from robot.alerts import engine as alerts_engine
from robot.alerts.models import Alert
from robot.alerts.services import alert_acknowledge
from robot.live.groups import ALERTS_KEY
from tests.conftest import EITHER_ROS
from tests.helpers import async_wait_until, receive_until, ws_communicator

pytestmark = pytest.mark.django_db(transaction=True)


@pytest.fixture
def sim(request):
    from simulator.harness import SimThread

    ros = getattr(request, "param", 1)
    with SimThread(port=0, video_port=0, startup_s=0.5, battery_soc=0.08, ros=ros) as running:
        yield running


@pytest.fixture
async def raiser(link):
    task = asyncio.ensure_future(alerts_engine.run_alerts(link))
    yield task
    task.cancel()
    await asyncio.gather(task, return_exceptions=True)


def on_now(frame: dict) -> dict[str, dict]:
    return {a["key"]: a for a in frame["msg"]["alerts"]}


async def alerts_frame(communicator, predicate, timeout=10.0) -> dict:
    return await receive_until(
        communicator, lambda f: f["kind"] == "update" and f["key"] == ALERTS_KEY and predicate(on_now(f)),
        timeout=timeout)


@EITHER_ROS
async def test_it_raises_shows_keeps_and_hands_over_alerts(link, sim, raiser, viewer, operator):
    # The robot's log: rosgraph_msgs/Log on ROS 1, rcl_interfaces/msg/Log (levels 10-50, no header) on ROS 2.
    await async_wait_until(lambda: link.dial.ros_version == sim.robot.ros, timeout=10, what="the link to find the ROS")
    communicator = ws_communicator(viewer)
    assert (await communicator.connect(timeout=10))[0]
    await communicator.send_json_to({"action": "watch", "keys": [ALERTS_KEY]})
    battery = on_now(await alerts_frame(communicator, lambda on: "battery_low" in on))["battery_low"]
    assert battery["severity"] == "critical" and battery["text"] == "Battery low: 8 %"

    sim.call(lambda: sim.robot.bus.rosout(16, "/move_base", "planner crashed"))
    sim.call(lambda: sim.robot.bus.rosout(8, "/move_base", "still broken"))
    log = on_now(await alerts_frame(communicator, lambda on: on.get("log:/move_base", {}).get("count") == 2))
    assert log["log:/move_base"]["text"] == "ERROR from /move_base: still broken"

    for _ in range(250):
        if await Alert.objects.filter(key="battery_low", ended_at=None).aexists():
            break
        await asyncio.sleep(0.02)
    else:
        raise AssertionError("the battery alert was not kept")
    # The raiser stops (a link handing over); the next takes the open alerts over with their id and start.
    raiser.cancel()
    await asyncio.gather(raiser, return_exceptions=True)
    second = asyncio.ensure_future(alerts_engine.run_alerts(link))
    try:
        again = await alerts_frame(communicator, lambda on: "battery_low" in on and "log:/move_base" in on)
        assert on_now(again)["battery_low"]["id"] == battery["id"]
        assert on_now(again)["battery_low"]["started_at"] == pytest.approx(battery["started_at"], abs=1e-3)

        # Acknowledged by an operator: an event ends (kept with who and when); a viewer may not.
        with pytest.raises(Exception, match="operators"):
            await sync_to_async(alert_acknowledge)(user=viewer, alert_id=log["log:/move_base"]["id"])
        acked = await sync_to_async(alert_acknowledge)(user=operator, alert_id=log["log:/move_base"]["id"])
        await alerts_frame(communicator, lambda on: "log:/move_base" not in on)
        row = await Alert.objects.aget(id=uuid.UUID(acked["id"]))
        assert row.acked_by_name == operator.username and row.ended_at is not None and row.count == 2
    finally:
        second.cancel()
        await asyncio.gather(second, return_exceptions=True)
    await communicator.disconnect()


async def test_an_alert_acknowledged_before_it_is_kept_is_kept_acknowledged(link, sim, raiser, operator,
                                                                           monkeypatch):
    from robot.alerts import records

    held = threading.Event()
    save = records.save

    def held_save(record):  # the database away for a moment: the raiser tries again a second later
        if not held.is_set():
            raise OperationalError("away")
        save(record)

    monkeypatch.setattr(records, "save", held_save)
    def hearing() -> bool:
        return link in alerts_engine._engines and "battery_low" in alerts_engine._engines[link].book.active

    await async_wait_until(hearing, timeout=10, what="the raiser hearing the robot")
    engine = alerts_engine._engines[link]
    sim.call(lambda: sim.robot.bus.rosout(8, "/laser", "driver died"))
    await async_wait_until(lambda: "log:/laser" in engine.book.active, timeout=10, what="the alert raised")
    on = engine.book.active["log:/laser"]
    assert not await Alert.objects.filter(id=uuid.UUID(on.id)).aexists()

    acked = await sync_to_async(alert_acknowledge)(user=operator, alert_id=on.id)
    assert acked["id"] == on.id and acked["acked_by"] == operator.username and acked["ended_at"] is not None
    assert "log:/laser" not in engine.book.active
    held.set()
    for _ in range(500):
        row = await Alert.objects.filter(id=uuid.UUID(on.id)).afirst()
        if row is not None and row.acked_at is not None:
            break
        await asyncio.sleep(0.02)
    assert row is not None and row.acked_by_name == operator.username and row.ended_at is not None


async def test_the_estop_raises_a_critical_alert_until_it_is_released(link, sim, raiser, viewer, operator):
    from robot.estop.stop import estop_release, estop_run

    communicator = ws_communicator(viewer)
    assert (await communicator.connect(timeout=10))[0]
    await communicator.send_json_to({"action": "watch", "keys": [ALERTS_KEY]})
    await alerts_frame(communicator, lambda on: "battery_low" in on)
    await estop_run(user=operator, source="api")
    estop = on_now(await alerts_frame(communicator, lambda on: "estop" in on))["estop"]
    assert estop["severity"] == "critical" and operator.username in estop["text"]
    await estop_release(user=operator, source="api", confirm=True)
    await alerts_frame(communicator, lambda on: "estop" not in on)
    await communicator.disconnect()


def _offline_on(engine: alerts_engine.AlertEngine) -> bool:
    return any(a["key"] == "offline" for a in engine.book.snapshot()["alerts"])


def test_the_first_start_is_no_outage_until_the_robot_had_time_to_come_up():
    from robot.link.connection import RobotLink
    from robot.live.state import get_store

    link = RobotLink("ws://127.0.0.1:9", store=get_store(), layer=None, request_queue="unused")
    engine = alerts_engine.AlertEngine(link)
    t0 = 1_000_000.0
    for dt in (0.0, 3.0, 10.0, 25.0):  # a simulator still starting
        engine.tick(t0 + dt)
        assert not _offline_on(engine), dt
    engine.tick(t0 + alerts_engine.FIRST_CONNECT_GRACE_S + 1)  # never came up: that is an outage
    assert _offline_on(engine)


def test_a_robot_that_was_connected_is_offline_after_the_blink_grace():
    from robot.link.connection import RobotLink
    from robot.live.state import get_store

    link = RobotLink("ws://127.0.0.1:9", store=get_store(), layer=None, request_queue="unused")
    engine = alerts_engine.AlertEngine(link)
    link.dial.connected = True
    engine.tick(1_000_000.0)
    link.dial.connected = False
    engine.tick(1_000_001.0)
    assert not _offline_on(engine)
    engine.tick(1_000_001.0 + alerts_engine.OFFLINE_GRACE_S + 0.5)
    assert _offline_on(engine)
