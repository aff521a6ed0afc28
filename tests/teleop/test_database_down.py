"""The E-STOP with the database down, for real (a private PostgreSQL stopped and started): a page's
session and a script's token still stop the robot, every other command is refused before it
reaches the robot, and every one of them is audited once the database returns."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import time

import pytest

from robot import interface as ri
from tests.helpers import wait_until
from tests.stack import Stack
from tests.support_processes import Client, Script, online_on_private_postgres, received
from tests.teleop.test_redis_fault import healthz


@pytest.fixture
def stack():
    with online_on_private_postgres() as running:
        yield running


def _zero_within(stack: Stack, pressed: float, within_s: float) -> bool:
    zero = [m for m in received(stack) if m["t"] >= pressed and ri.is_zero_twist(m["msg"])]
    return bool(zero) and zero[0]["t"] - pressed <= within_s


def test_the_estop_works_and_nothing_else_reaches_the_robot_while_the_database_is_down(stack):
    page, script = Client(stack, "otto"), Script(stack, "olga")
    assert script.post("/api/robot/speech/", {"text": "before"})[0] == 200  # the token is now trusted
    speech = ri.topic("text_to_speech").name
    said = len(received(stack, speech))

    stack.postgres.stop()
    pressed = time.time()
    status, body = page.post("/api/robot/estop/")
    assert status == 200 and all(step["ok"] for step in body["steps"]), body
    assert body["latch"]["by"] == "otto"
    wait_until(lambda: _zero_within(stack, pressed, 0.5), timeout=5, what="a zero Twist within 500 ms of the press")
    for path, payload in (("/api/robot/speech/", {"text": "unaudited"}), ("/api/robot/motors/", {"enabled": False}),
                          ("/api/robot/mode/", {"mode": "stop"})):
        status, body = script.post(path, payload)
        assert (status, body["code"]) == (503, "unavailable"), (path, body)
    status, body = script.post("/api/robot/estop/release/", {"confirm": True})
    assert status == 200 and not body["latched"], body
    pressed = time.time()
    status, body = script.post("/api/robot/estop/")
    assert status == 200 and body["latch"]["by"] == "olga", body
    wait_until(lambda: _zero_within(stack, pressed, 0.5), timeout=5, what="a zero Twist within 500 ms of the press")
    assert len(received(stack, speech)) == said  # nothing refused reached the robot
    status, health = healthz(stack)
    assert status == 503 and {"database", "audit"} <= set(health["down"]), health

    stack.postgres.start()
    rows: list[tuple] = []

    def audited() -> bool:
        status, body = page.get("/api/audit/?limit=100")
        rows[:] = [(r["username"], r["action"], r["ok"], r["error_code"], r["address"])
                   for r in reversed(body.get("results", []))
                   # the stack's set-up: accounts, tokens, default recording policies
                   if not r["action"].startswith(("account.", "token.", "setting."))]
        return status == 200 and len(rows) == 7

    wait_until(audited, timeout=20, what="the journaled audit entries")
    assert rows == [(*row, "127.0.0.1") for row in (  # every row with the client's address
        ("olga", "speech", True, ""), ("otto", "estop", True, ""), ("olga", "speech", False, "unavailable"),
        ("olga", "motors", False, "unavailable"), ("olga", "mode", False, "unavailable"),
        ("olga", "estop.release", True, ""), ("olga", "estop", True, ""),
    )]
    wait_until(lambda: script.post("/api/robot/estop/release/", {"confirm": True})[0] == 200, timeout=10,
               what="commands accepted again")
    assert script.post("/api/robot/speech/", {"text": "after"})[0] == 200
    assert healthz(stack)[0] == 200


def _postgres_processes(postgres) -> list[int]:
    main = int((postgres.data / "postmaster.pid").read_text().split()[0])
    children = subprocess.run(["ps", "-o", "pid=", "--ppid", str(main)], capture_output=True, text=True).stdout
    return [main, *map(int, children.split())]


def _signal_all(pids: list[int], sig: int) -> None:
    """``sig`` to each (a backend that ended since it was listed is skipped)."""
    for pid in pids:
        with contextlib.suppress(ProcessLookupError):
            os.kill(pid, sig)


def test_the_estop_works_with_the_database_frozen(stack):
    page, script = Client(stack, "otto"), Script(stack, "olga")
    assert script.post("/api/robot/speech/", {"text": "before"})[0] == 200
    frozen = _postgres_processes(stack.postgres)
    try:
        _signal_all(frozen, signal.SIGSTOP)
        for who in (page, script):
            pressed = time.time()
            status, body = who.post("/api/robot/estop/")
            answered = time.time() - pressed
            wait_until(lambda t=pressed: _zero_within(stack, t, 0.5), timeout=5, what="a zero Twist within 500 ms")
            assert status == 200 and answered <= 1.0, (status, answered, body)
            assert who.post("/api/robot/estop/release/", {"confirm": True})[0] == 200
    finally:
        _signal_all(frozen, signal.SIGCONT)

    def audited() -> bool:
        status, body = page.get("/api/audit/?action=estop&limit=5")
        return status == 200 and len(body["results"]) == 2

    wait_until(audited, timeout=20, what="both presses audited once the database answers")
