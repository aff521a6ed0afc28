"""Any mode from any state, with both commander strategies, against the simulator.

The simulator plays the robot's commander for the ``robot`` strategy, running the thesis's
sequences as the robot does (so from inside behaviour they fail on their own); the server
must walk the state machine to suspension first either way.
"""

from __future__ import annotations

import itertools

import pytest

from robot import interface as ri
from robot.commands import modes
from simulator.harness import SimThread
from simulator.nodes import controller
from tests.commands.support import until_the_server_hears, wait_ready

B, D, M, S = ri.Mode.BEHAVIOUR, ri.Mode.DEMO, ri.Mode.MANUAL, ri.Mode.STOP
# Every ordered pair of the four modes exactly once (an Euler circuit of the complete graph with loops).
CIRCUIT = (S, S, B, B, D, D, M, M, S, D, B, M, B, S, M, D, S)
# Behaviour's inner states, each with the events that lead there from idle.
INNER_STATES: dict[str, tuple[str, ...]] = {
    "show_off_mea": ("show_off_mea",),
    "conveying_emotional_state": ("convey_emotion",),
    "music_horror": ("music_play",),
    "astrolanguage": ("astrolanguage",),
    "sleepy": ("bedtime",),
    "sleeping": ("bedtime", "succeeded"),
    "waking_up": ("bedtime", "succeeded", "cyborg_wake_up"),
    "exhausted": ("power_low",),
    "navigation_planning": ("navigation_emotional",),
    "navigation_go_to_emotional": ("navigation_emotional", "navigation_go_to_emotional"),
    "navigation_go_to_schedular": ("navigation_schedular", "navigation_go_to_schedular"),
    "wandering_emotional": ("navigation_emotional", "wandering_emotional"),
}
PAUSE_S = 0.05


@pytest.fixture
def sim():
    """States stay where they are put (long demo and behaviours); a short commander pause."""
    with SimThread(port=0, video_port=0, startup_s=0.5, demo_s=600, behaviour_s=600,
                   commander_pause_s=PAUSE_S) as running:
        yield running


@pytest.fixture(params=["server", "robot"])
def strategy(request, settings, monkeypatch):
    settings.MODE_COMMANDER = request.param
    monkeypatch.setattr(ri, "COMMANDER_PAUSE_S", PAUSE_S)
    return request.param


def sim_state(sim) -> str:
    return sim.call(lambda: sim.robot.controller.sm.state)


async def change(sim, mode: ri.Mode, start: str) -> None:
    outcome = await modes.perform_mode(mode)
    state = sim_state(sim)
    assert modes.state_reached(mode, state), f"{start} → {mode.short}: the simulator is in {state} ({outcome})"


async def test_every_mode_is_reached_from_every_mode(link, sim, strategy):
    wait_ready(sim)
    await until_the_server_hears(lambda s: s == "suspension", "suspension")
    for before, after in itertools.pairwise(CIRCUIT):
        assert modes.state_reached(before, sim_state(sim))
        await change(sim, after, before.short)


def enter(sim, events: tuple[str, ...]) -> str:
    """Fire ``events`` from idle in one go on the simulator's loop; the state they led to."""
    def fire() -> str:
        assert sim.robot.controller.sm.state == "idle", sim.robot.controller.sm.state
        for event in events:
            assert sim.robot.controller.fire(event), event
        return sim.robot.controller.sm.state
    return sim.call(fire)


async def test_every_mode_is_reached_from_inside_behaviour(link, sim, strategy):
    wait_ready(sim)
    await until_the_server_hears(lambda s: s == "suspension", "suspension")
    for inner, events in INNER_STATES.items():
        for mode in (B, D, M, S):
            await change(sim, B, "suspension")
            assert enter(sim, events) == inner
            await until_the_server_hears(lambda s: s != "idle", inner)  # what an operator would see first
            await change(sim, mode, inner)


async def test_it_names_the_step_that_failed(link, sim, settings, monkeypatch):
    settings.MODE_COMMANDER = "server"
    monkeypatch.setattr(ri, "COMMANDER_PAUSE_S", PAUSE_S)
    monkeypatch.setattr(modes, "STEP_TIMEOUT_S", 0.5)
    wait_ready(sim)
    await until_the_server_hears(lambda s: s == "suspension", "suspension")
    await change(sim, D, "suspension")
    # A robot whose demo state ignores `aborted` (a broken controller): the walk stops there, saying so.
    monkeypatch.setitem(controller.TABLE, "demo", {})
    with pytest.raises(modes.ModeStepFailed) as failure:
        await modes.perform_mode(M)
    assert failure.value.message.startswith(
        "Manual mode not reached: step 2 (event aborted (demo → suspension)) failed: no state_change for it "
        "within 0.5 s (ignored?); the state machine is in demo. Done before it: emotion system OFF.")
