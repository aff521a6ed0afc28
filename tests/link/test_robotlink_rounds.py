"""The robotlink command's rounds as the holder: a round that fails (its link would not start, Redis
restarting under it) is logged, hands the lease back and ends in standby, never in a dead process;
a link that fails to start leaves nothing of itself running."""

from __future__ import annotations

import asyncio
import logging
import types

import pytest
from redis.exceptions import ConnectionError as RedisConnectionError

from robot.link import hosting
from robot.link.connection import RobotLink
from robot.link.lease import Lease
from robot.management.commands import robotlink
from tests.support_processes import PrivateRedis


@pytest.fixture
def private_redis(settings):
    server = PrivateRedis().start()
    settings.REDIS_URL, settings.EMBEDDED = server.url, False  # the scaled wiring: a leased link
    settings.ROBOT_LINK_LEASE_S = 0.5
    yield server
    server.stop()


async def test_failed_rounds_are_logged_and_the_link_stands_by_again_its_link_stopped(
        private_redis, monkeypatch, caplog):
    """Round 1: the link fails to start. Round 2: it runs, then renewing the lease fails. Round 3: a stop."""
    stop = asyncio.Event()
    held_at_start: list[bool] = []
    stopped: list[object] = []
    links = [types.SimpleNamespace(dial=types.SimpleNamespace(url=f"ws://robot/{n}")) for n in range(3)]
    real_hold = Lease.hold

    async def start_link(*, embedded: bool, lease: Lease) -> tuple[object, list]:
        held_at_start.append(lease.held)
        if len(held_at_start) == 1:
            raise RedisConnectionError("Connection closed by server.")
        if len(held_at_start) == 3:
            stop.set()
        return links[len(held_at_start) - 1], []

    async def stop_link(link, tasks) -> None:
        stopped.append(link)

    async def hold(lease: Lease) -> None:
        if len(held_at_start) == 2:
            raise ValueError("a renewal that went wrong")
        await real_hold(lease)

    monkeypatch.setattr(robotlink, "start_link", start_link)
    monkeypatch.setattr(robotlink, "stop_link", stop_link)
    monkeypatch.setattr(Lease, "hold", hold)
    monkeypatch.setattr(robotlink, "RETRY_AFTER_FAILURE_S", 0.1)
    with caplog.at_level(logging.INFO):
        await asyncio.wait_for(robotlink.Command()._run_leased(stop), 30)

    assert held_at_start == [True, True, True], "each round started only while holding the lease"
    assert stopped == links[1:], "every link that started was stopped, the failed round's too"
    assert caplog.text.count("failed; standby again") == 2
    assert "Connection closed by server." in caplog.text and "a renewal that went wrong" in caplog.text
    assert caplog.text.count("released its lease") >= 3, "each round handed the lease back"


async def test_a_link_that_fails_to_start_is_stopped_before_the_error_goes_on(monkeypatch):
    stopped: list[RobotLink] = []

    async def start(self: RobotLink, **_: object) -> None:
        raise RedisConnectionError("Connection closed by server.")

    async def stop(self: RobotLink) -> None:
        stopped.append(self)

    monkeypatch.setattr(RobotLink, "start", start)
    monkeypatch.setattr(RobotLink, "stop", stop)
    with pytest.raises(RedisConnectionError):
        await hosting.start_link(embedded=False)
    assert len(stopped) == 1, "what the link had started (a rosbridge connection, its loops) is left running"


async def test_the_wait_for_the_lease_or_a_stop_passes_on_the_error_of_what_it_waited_for():
    async def fails() -> None:
        raise RedisConnectionError("Connection closed by server.")

    with pytest.raises(RedisConnectionError):
        await robotlink._first(fails(), asyncio.Event().wait())
