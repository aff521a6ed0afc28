"""Helpers for the commanding tests: what reached the simulated robot, and audit lookups."""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable
from typing import Any

from asgiref.sync import async_to_sync

from robot import interface as ri
from robot.commands.statewatch import StateWatch
from robot.models import AuditEntry
from tests.helpers import DEADLINE_S, wait_until

# Every topic a command may publish on.
COMMAND_TOPICS = ("robot_mode", "register_event", "emotional_controller", "set_emotional_state",
                  "text_to_speech", "playback", "domecontrol")

# (path, valid body) for every command endpoint.
ENDPOINTS: dict[str, dict[str, Any]] = {
    "/api/robot/mode/": {"mode": "manual"},
    "/api/robot/event/": {"event": "aborted"},
    "/api/robot/speech/": {"text": "hello"},
    "/api/robot/emotion/": {"emotion": "angry"},
    "/api/robot/emotion-system/": {"on": False},
    "/api/robot/motors/": {"enabled": False},
    "/api/robot/playback/": {"clip": "hello_there"},
    "/api/robot/dome/": {"mode": "rainbow"},
}


def received(sim, key: str) -> list[dict[str, Any]]:
    return sim.received(ri.topic(key).name)


def motor_calls(sim) -> int:
    """The simulated RosAria logs every motors service call it serves."""
    log = sim.call(lambda: list(sim.robot.bus.rosout_log))
    return sum(1 for m in log if m["name"] == "/RosAria" and m["msg"].startswith("Motors "))


def sent_to_robot(sim) -> dict[str, int]:
    counts = {key: sim.received_count(ri.topic(key).name) for key in COMMAND_TOPICS}
    counts["motors"] = motor_calls(sim)
    return counts


def only_the_marker_arrived(sim, operator_api) -> bool:
    """Send a marker command after the refused ones: once it has arrived, anything sent before
    it would have too, so "nothing else reached the robot" is a real check, not a race."""
    assert operator_api.post("/api/robot/speech/", {"text": "marker"}, format="json").status_code == 200
    wait_until(lambda: sim.received_count(ri.topic("text_to_speech").name) >= 1, what="the marker")
    counts = sent_to_robot(sim)
    assert received(sim, "text_to_speech") == [{"data": "marker"}], received(sim, "text_to_speech")
    return counts == {**dict.fromkeys(counts, 0), "text_to_speech": 1}


def wait_state(sim, predicate, what: str, timeout: float = 10.0) -> dict[str, Any]:
    return wait_until(lambda: (s := sim.snapshot()["state"]) and predicate(s) and s, timeout=timeout, what=what)


def wait_ready(sim) -> None:
    """Startup finished: the state machine waits in suspension."""
    wait_state(sim, lambda s: s["smach_state"] == "suspension", "startup to finish")


def wait_server_ready() -> None:
    """The server has heard that startup finished (mode changes plan from what it has heard)."""
    wait_until(lambda: async_to_sync(StateWatch().start)() == "suspension", timeout=15,
               what="the server to hear of suspension")


def last_audit() -> AuditEntry:
    entry = AuditEntry.objects.first()
    assert entry is not None, "no audit entry was written"
    return entry


async def until_the_server_hears(accept: Callable[[str], bool], what: str, timeout: float = DEADLINE_S) -> str:
    """Wait for the link to report a state ``accept`` takes (the state the server plans from)."""
    deadline = time.monotonic() + timeout
    while not accept(state := await StateWatch().start()):
        assert time.monotonic() < deadline, f"the server never heard of {what} (it knows {state!r})"
        await asyncio.sleep(0.02)
    return state
