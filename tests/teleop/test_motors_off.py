"""Motors off (an E-STOP release leaves them off): moves are refused with that reason, never
accepted to go nowhere; a hung robot is not handed the drive lock; a driver is told who took over."""

import asyncio
import os
import signal

import pytest

from robot.live.announce import aget_state
from robot.models import AuditEntry
from robot.teleop.lock import get_lock
from tests.helpers import async_wait_until, receive_until
from tests.link.test_liveness import frozen_link, sim_process  # noqa: F401  (a simulator process to freeze)
from tests.teleop.support import drive_socket, error_frame, is_moving, key, lock_frame, twists, wait_twist

pytestmark = pytest.mark.django_db(transaction=True)


async def motors(sim, on: bool) -> None:
    """The robot switches its motors (as its E-STOP step does); wait until the link heard it say so."""
    await asyncio.to_thread(sim.call, lambda: sim.robot.base_node.set_motors(on))

    async def said() -> bool:
        return (await aget_state("motors_state")).get("motors_state", {}).get("data") is on

    deadline = asyncio.get_running_loop().time() + 10
    while not await said():
        assert asyncio.get_running_loop().time() < deadline, f"the robot never said motors {on}"
        await asyncio.sleep(0.05)


async def test_driving_with_the_motors_off_is_refused_with_the_reason(link, sim, operator):
    await motors(sim, False)
    ws = await drive_socket(operator)
    await ws.send_json_to(key(1.0))
    refused = await error_frame(ws)
    assert refused["code"] == "motors_off" and "Motors off" in refused["message"], refused
    await asyncio.sleep(0.3)
    assert not any(is_moving(t) for t in await twists(sim))
    assert await AuditEntry.objects.filter(action="teleop.input", ok=False, outcome__startswith="Motors off").aexists()
    # A stop is never refused; with the motors on again the same input drives.
    await ws.send_json_to({"type": "release"})
    await motors(sim, True)
    await ws.send_json_to(key(1.0))
    await wait_twist(sim, is_moving)
    await ws.disconnect()


async def test_motors_switched_off_while_driving_stop_the_driver_and_say_why(link, sim, operator):
    ws = await drive_socket(operator)
    await ws.send_json_to(key(0.5))
    await wait_twist(sim, is_moving)
    await motors(sim, False)
    seen = len(await twists(sim))
    await ws.send_json_to(key(0.6))
    assert (await error_frame(ws))["code"] == "motors_off"
    await wait_twist(sim, lambda t: not is_moving(t), after=seen)  # the driver's loop sent its zero
    await ws.disconnect()
    await motors(sim, True)


async def test_a_driver_is_told_who_took_over(link, sim, operator, admin_user):
    otto_ws, ada_ws = await drive_socket(operator), await drive_socket(admin_user)
    await otto_ws.send_json_to({"type": "acquire"})
    await lock_frame(otto_ws, lambda f: f["you"])
    await ada_ws.send_json_to({"type": "takeover"})
    notice = await receive_until(otto_ws, lambda f: f["type"] == "notice")
    assert notice["code"] == "takeover" and "ada took over" in notice["message"], notice
    await otto_ws.disconnect()
    await ada_ws.disconnect()


async def test_a_hung_robot_is_not_handed_the_drive_lock(frozen_link, sim_process, operator):  # noqa: F811
    ws = await drive_socket(operator)
    os.kill(sim_process.pid, signal.SIGSTOP)
    await async_wait_until(lambda: not frozen_link.dial.responding, timeout=10, what="the robot judged not responding")
    await ws.send_json_to({"type": "acquire"})
    refused = await error_frame(ws)
    assert refused["code"] == "not_responding" and "not responding" in refused["message"], refused
    await ws.send_json_to(key(0.5))  # driving does not take it either
    assert (await error_frame(ws))["code"] == "not_responding"
    assert await get_lock().holder() is None
    os.kill(sim_process.pid, signal.SIGCONT)
    await async_wait_until(lambda: frozen_link.dial.responding, timeout=10, what="the robot answering again")
    await ws.send_json_to({"type": "acquire"})
    await lock_frame(ws, lambda f: f["you"])
    await ws.disconnect()


async def test_a_key_that_meets_the_stop_before_its_lock_news_is_refused_for_the_stop(link, sim, operator):
    """The E-STOP turns the motors off; a key still held by the driver, arriving before the news that
    the lock was taken, is refused for the stop (its true reason), audited once."""
    from robot.estop.latch import aengage, arelease

    ws = await drive_socket(operator)
    await ws.send_json_to(key(0.5))
    await wait_twist(sim, is_moving)
    await aengage(by="olga")  # the latch alone: no lock event reaches this driver
    try:
        await motors(sim, False)
        for _ in range(3):
            await ws.send_json_to(key(0.5))
            refused = await error_frame(ws)
            assert refused["code"] == "estop" and "E-STOP engaged by olga" in refused["message"], refused
        assert await AuditEntry.objects.filter(action="teleop.input", ok=False).acount() == 1
    finally:
        await arelease(by="olga")
        await motors(sim, True)
    await ws.disconnect()
