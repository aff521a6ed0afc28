"""Mode changes right after the robot restarts, with both commander strategies.

The robot process is stopped and started again on the same port; the state machine starts
over in ``startup`` without the link hearing a ``state_change`` for it (it was published
before the link reconnected). What the server heard before the restart must not count.
"""

from __future__ import annotations

import asyncio

import pytest

from robot import interface as ri
from robot.commands import modes
from robot.commands.statewatch import StateWatch
from robot.live.state import get_store
from simulator.harness import SimThread
from tests.commands.support import until_the_server_hears, wait_ready
from tests.helpers import async_wait_until

PAUSE_S = 0.05


@pytest.fixture
def sim():
    with SimThread(port=0, video_port=0, startup_s=0.5, demo_s=600, commander_pause_s=PAUSE_S) as running:
        yield running


@pytest.fixture
def revived():
    """The robot started again; set up before the link, so it stops after the link has (as in production,
    the link never stops while the robot is away)."""
    started: list[SimThread] = []
    yield started
    for sim in started:
        sim.stop()


@pytest.fixture(params=["server", "robot"])
def strategy(request, settings, monkeypatch):
    settings.MODE_COMMANDER = request.param
    monkeypatch.setattr(ri, "COMMANDER_PAUSE_S", PAUSE_S)
    return request.param


def state_of(sim: SimThread) -> str:
    return sim.call(lambda: sim.robot.controller.sm.state)


async def restart(link, sim: SimThread, revived: list[SimThread]) -> SimThread:
    """Stop the robot and start a new one on its port that stays in startup until told otherwise."""
    loop = asyncio.get_running_loop()
    before = link.dial.since
    await loop.run_in_executor(None, sim.stop)
    await async_wait_until(lambda: not link.connected, timeout=10, what="the link to notice the robot left")
    again = SimThread(port=sim.port, video_port=0, startup_s=600, demo_s=600, commander_pause_s=PAUSE_S)
    await loop.run_in_executor(None, again.start)
    revived.append(again)
    await async_wait_until(lambda: link.connected and link.dial.since > before, timeout=15, what="the link reconnected")
    assert state_of(again) == "startup"
    return again


async def heard_since_reconnect(link) -> None:
    """Wait for the robot's first report after the reconnect (its periodic SMACH status)."""
    since = link.dial.since
    await async_wait_until(lambda: any(e["t"] >= since for e in get_store().get_recent("smach_status")),
                           timeout=10, what="a SMACH status from the restarted robot")


@pytest.mark.parametrize("target", [ri.Mode.STOP, ri.Mode.DEMO, ri.Mode.MANUAL, ri.Mode.BEHAVIOUR],
                         ids=lambda m: m.short)
@pytest.mark.parametrize("when", ["at once", "after its first report"])
async def test_a_mode_change_after_a_restart_starts_from_startup_not_from_before(
        revived, link, sim, strategy, target, when):
    wait_ready(sim)
    await until_the_server_hears(lambda s: s == "suspension", "suspension")
    # The last thing the server heard before the restart: stop reached, from demo.
    await modes.perform_mode(ri.Mode.DEMO)
    await modes.perform_mode(ri.Mode.STOP)
    assert state_of(sim) == "suspension"

    robot = await restart(link, sim, revived)
    if when == "at once":
        assert await StateWatch().start() in ("", "startup")  # never the suspension from before
    else:
        await heard_since_reconnect(link)
        assert await StateWatch().start() == "startup"
    outcome = await modes.perform_mode(target)
    state = state_of(robot)
    assert modes.state_reached(target, state), f"startup → {target.short}: the robot is in {state} ({outcome})"
    assert "startup → suspension" in outcome, outcome  # it walked out of startup first


async def test_after_a_restart_the_robot_has_the_subscriptions_before_the_first_command(revived, link, sim):
    """What the robot says in answer to a command sent at once (a state_change) reaches the server: the
    link subscribes again on the new connection before it sends anything else there."""
    from robot.link.bus import apublish

    wait_ready(sim)
    robot = await restart(link, sim, revived)
    await apublish("text_to_speech", {"data": "hello again"})
    speech = ri.topic("text_to_speech").name
    await async_wait_until(lambda: robot.received_count(speech) > 0, timeout=10, what="the speech at the robot")
    assert robot.subscription_count(ri.topic("state_change").name) > 0
