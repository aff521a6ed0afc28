"""Liveness: a simulator process frozen with SIGSTOP is "not responding", and commands are refused
with that reason until it answers again (real process, real rosbridge socket, unmodified roslibpy)."""

import asyncio
import os
import signal
import subprocess
import sys

import pytest

from robot.link.bus import RobotNotResponding, apublish
from robot.link.liveness import judge
from robot.live.groups import STATUS_KEY
from robot.live.state import get_store, status_view
from tests.conftest import hosted_link
from tests.helpers import receive_until, ws_communicator
from tests.stack import ROOT, free_port, wait_for_port


def test_it_judges_a_robot_silent_past_the_hang_time_not_responding():
    assert judge(connected=True, heard_at=100.0, now=101.9, hang=2.0)
    assert not judge(connected=True, heard_at=100.0, now=102.0, hang=2.0)
    assert judge(connected=False, heard_at=0.0, now=500.0, hang=2.0)  # offline is not "not responding"


@pytest.fixture
def sim_process():
    port = free_port()
    proc = subprocess.Popen([sys.executable, "-m", "simulator", "--port", str(port), "--video-port", "0"],
                            cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        wait_for_port(port, proc=proc)
        proc.url = f"ws://127.0.0.1:{port}"
        yield proc
    finally:
        os.kill(proc.pid, signal.SIGCONT)
        proc.terminate()
        proc.wait(10)


@pytest.fixture
async def frozen_link(sim_process, settings):
    async for hosted in hosted_link(sim_process.url, settings, timeout=15):
        yield hosted


async def stored_status() -> dict:
    return status_view((await get_store().aget_many([STATUS_KEY])).get(STATUS_KEY))


async def test_a_frozen_robot_is_not_responding_and_refused_commands_until_it_answers(
        frozen_link, sim_process, viewer):
    communicator = ws_communicator(viewer)
    assert (await communicator.connect(timeout=10))[0]
    await receive_until(communicator, lambda f: f["kind"] == "status" and f["connected"], timeout=10)
    await apublish("register_event", {"data": "aborted"})  # answered while it talks

    os.kill(sim_process.pid, signal.SIGSTOP)
    frame = await receive_until(communicator, lambda f: f["kind"] == "status" and f.get("responding") is False,
                                timeout=5)
    assert frame["robot_connected"] is True and frame["connected"] is False
    assert (await stored_status())["responding"] is False
    with pytest.raises(RobotNotResponding, match="not responding"):
        await apublish("register_event", {"data": "aborted"})
    with pytest.raises(RobotNotResponding):
        await apublish("cmd_vel", {"linear": {"x": 0.2, "y": 0, "z": 0}, "angular": {"x": 0, "y": 0, "z": 0}})
    # Zero velocity still goes: stopping a robot is never refused.
    await apublish("cmd_vel", {"linear": {"x": 0, "y": 0, "z": 0}, "angular": {"x": 0, "y": 0, "z": 0}})

    os.kill(sim_process.pid, signal.SIGCONT)
    await receive_until(communicator, lambda f: f["kind"] == "status" and f["connected"] and f["responding"],
                        timeout=10)
    await apublish("register_event", {"data": "aborted"})
    await communicator.disconnect()


@pytest.mark.django_db(transaction=True)
async def test_driving_a_frozen_robot_is_refused_with_the_reason(frozen_link, sim_process, operator):
    from tests.teleop.support import drive_socket, error_frame, key, lock_frame

    ws = await drive_socket(operator)
    await ws.send_json_to(key(0.5))
    await lock_frame(ws, lambda f: f["you"])
    await ws.send_json_to({"type": "release"})
    os.kill(sim_process.pid, signal.SIGSTOP)
    for _ in range(50):
        if not frozen_link.dial.responding:
            break
        await asyncio.sleep(0.1)
    assert not frozen_link.dial.responding
    await ws.send_json_to(key(0.5))
    error = await error_frame(ws)
    assert "not responding" in error["message"], error
    await ws.disconnect()
