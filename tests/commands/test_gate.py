"""The E-STOP's gate in the pipeline: every command declares whether it moves the robot, and the
pipeline refuses those (409, audited) while the E-STOP is latched, before anything is sent."""

import re
from pathlib import Path
from typing import Any

import pytest

from robot import interface as ri
from robot.commands.pipeline import Command
from robot.commands.tool import STRING_COMMANDS
from robot.estop.rule import MOVES

ROBOT = Path(__file__).resolve().parents[2] / "robot"

# Every command, and what the E-STOP does with it: (inputs it holds back, inputs it lets through).
DECLARED: dict[str, tuple[list[Any], list[Any]]] = {
    "estop": ([], [None]),
    "estop.release": ([], [None]),
    "mode": ([ri.Mode.BEHAVIOUR, ri.Mode.DEMO, ri.Mode.MANUAL], [ri.Mode.STOP]),
    "event": ([ri.Event.BEHAVIOUR_START, ri.Event.ABORTED], []),
    "speech": ([], ["hello"]),
    "emotion": ([], ["angry"]),
    "emotion_system": ([ri.EMOTION_SYSTEM_ON], [ri.EMOTION_SYSTEM_OFF]),
    "playback": ([], ["horror"]),
    "dome": ([], ["rainbow"]),
    "motors": ([True], [False]),
    "navigation.goal": ([(1.0, 2.0, 0.0)], []),
    "navigation.cancel": ([], [None]),
    "navigation.initial_pose": ([(1.0, 2.0, 0.0)], []),
    "navigation.go_to": (["lab"], []),
    "teleop.lock": ([None], []),
    "teleop.takeover": ([None], []),
    "audio.listen.start": ([], [None]),
    "link.reconnect": ([], [None]),
    "audio.talk.start": ([None], []),
    "frontdoor.publish": ([None], []),
    "frontdoor.call": ([None], []),
}


def test_every_command_declares_what_the_estop_does_with_it():
    assert set(MOVES) == set(DECLARED)
    for action, (held, passed) in DECLARED.items():
        assert [MOVES[action](value) for value in held] == [True] * len(held), action
        assert [MOVES[action](value) for value in passed] == [False] * len(passed), action


def test_every_command_the_product_builds_is_declared():
    """Each action the product names when it builds a command (Command(...), arun_command(...),
    the command tool's table) is in the table, and every entry of the table is used."""
    built: set[str] = set(STRING_COMMANDS)
    for path in ROBOT.rglob("*.py"):
        text = path.read_text()
        built |= set(re.findall(r'\bCommand\(\s*"([\w.]+)"', text))
        for call in re.findall(r"\barun_command\((.*?)\)\n", text, re.S):
            built |= set(re.findall(r'action="([\w.]+)"', call))
    assert built == set(MOVES)


def test_an_undeclared_command_cannot_be_built():
    async def send(_: Any) -> str:
        return "sent"

    with pytest.raises(LookupError, match="not declared"):
        Command("made.up", {}, send)


@pytest.mark.django_db(transaction=True)
async def test_under_the_latch_what_moves_is_refused_and_audited_and_the_rest_is_sent(operator):
    from robot.commands.pipeline import arun
    from robot.estop.latch import aengage, arelease
    from robot.link.bus import EstopEngaged
    from robot.models import AuditEntry

    sent: list[str] = []

    def command(action: str, checked: Any) -> Command:
        async def send(_: Any) -> str:
            sent.append(action)
            return "sent"

        return Command(action, {}, send, check=lambda: checked, check_on_loop=True)

    await aengage(by="olga")
    try:
        for action, value in (("mode", ri.Mode.DEMO), ("motors", True), ("event", "demo_start")):
            with pytest.raises(EstopEngaged, match="E-STOP engaged by olga"):
                await arun(command(action, value), user=operator, source="api")
        for action, value in (("mode", ri.Mode.STOP), ("motors", False), ("speech", "hi")):
            assert await arun(command(action, value), user=operator, source="api") == "sent"
    finally:
        await arelease(by="olga")
    assert sent == ["mode", "motors", "speech"]
    refused = [e async for e in AuditEntry.objects.filter(ok=False).order_by("id")]
    assert [(e.action, e.error_code) for e in refused] == [("mode", "estop"), ("motors", "estop"), ("event", "estop")]
    assert await arun(command("event", "demo_start"), user=operator, source="api") == "sent"


def test_without_the_estops_gate_no_command_can_be_built(monkeypatch):
    from robot.commands import pipeline

    monkeypatch.setattr(pipeline, "_gate", [])
    with pytest.raises(LookupError, match="gate is not installed"):
        Command("speech", {}, send=lambda _: None)  # type: ignore[arg-type, return-value]
