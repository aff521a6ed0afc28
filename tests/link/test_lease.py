"""The robot link's lease on a private redis-server: one holder, handed over on release, fenced
publishes, taken back by its holder when Redis restarts empty."""

from __future__ import annotations

import asyncio
import random

import pytest
import redis

from robot import interface as ri
from robot.link.lease import Lease
from tests.helpers import DEADLINE_S, async_wait_until
from tests.support_processes import PrivateRedis

KEY = "test:link-lease"
TTL_S = 2.0  # the default ROBOT_LINK_LEASE_S


@pytest.fixture
def redis_server():
    server = PrivateRedis().start()  # a standby waits a lease's time after Redis starts (see the last test)
    yield server
    server.stop()


@pytest.fixture
async def leases(redis_server):
    made: list[Lease] = []

    def make(holder: str, ttl_s: float = TTL_S) -> Lease:
        made.append(Lease(redis_server.url, KEY, holder=holder, ttl_s=ttl_s, poll_s=0.05))
        return made[-1]

    yield make
    for lease in made:
        await lease.close()


async def _take_over(redis_server: PrivateRedis, lease: Lease) -> None:
    """The key expires (the holder stalled) and ``lease`` takes it."""
    redis.Redis.from_url(redis_server.url).delete(KEY)
    await asyncio.wait_for(lease.acquire(), DEADLINE_S)


async def test_one_holder_at_a_time_and_a_release_hands_over_at_once(leases, redis_server):
    a, b = leases("link-a"), leases("link-b")
    await asyncio.wait_for(a.acquire(), DEADLINE_S)
    renewing = asyncio.ensure_future(a.hold())
    waiting = asyncio.ensure_future(b.acquire())
    await asyncio.sleep(1.5 * TTL_S)  # the holder renews: the standby never gets it
    assert not waiting.done() and await a.check()

    await a.release()
    assert redis.Redis.from_url(redis_server.url).get(KEY) in (None, b.token)  # given up, not left to expire
    await asyncio.wait_for(renewing, DEADLINE_S)
    assert not a.held and not await a.check()
    # Handed over at the standby's next poll, not left to expire. (A standby that began waiting while
    # the server was younger than a lease first waits a lease's time: the deadline leaves room for it.)
    await asyncio.wait_for(waiting, DEADLINE_S)
    assert b.held and await b.check()


async def test_a_holder_whose_lease_was_taken_knows_at_its_next_check(leases, redis_server):
    a, b = leases("link-a"), leases("link-b")
    await asyncio.wait_for(a.acquire(), DEADLINE_S)
    await _take_over(redis_server, b)

    assert not await a.check()
    assert a.lost.is_set() and not a.held
    assert await b.check()


async def test_a_link_that_lost_its_lease_never_commands_the_robot(link, sim, leases, redis_server):
    a, b = leases("link-a"), leases("link-b")
    await asyncio.wait_for(a.acquire(), DEADLINE_S)
    renewing = asyncio.ensure_future(a.hold())
    link.requests.lease = a
    speech = ri.topic("text_to_speech")
    request = {"op": "publish", "topic": speech.name, "msg_type": speech.type}

    reply = await link.requests.execute({**request, "msg": {"data": "while holding"}})
    assert reply["ok"], reply
    await async_wait_until(lambda: {"data": "while holding"} in sim.received(speech.name), what="the command")

    await _take_over(redis_server, b)
    reply = await link.requests.execute({**request, "msg": {"data": "after losing it"}})
    assert not reply["ok"] and "lost its lease" in reply["error"]
    await asyncio.sleep(0.5)
    assert {"data": "after losing it"} not in sim.received(speech.name)
    link.requests.lease = None
    await asyncio.wait_for(renewing, DEADLINE_S)  # the renewal finds the other token and gives up too


async def test_after_redis_restarts_empty_the_holder_takes_its_lease_back(leases, redis_server):
    ttl_s = 4.0  # Redis is back well inside it: the holder never stops holding
    a, b = leases("link-a", ttl_s), leases("link-b", ttl_s)
    await asyncio.wait_for(a.acquire(), 2 * ttl_s)
    renewing = asyncio.ensure_future(a.hold())
    waiting = asyncio.ensure_future(b.acquire())

    redis_server.stop()
    redis_server.start()
    client = redis.Redis.from_url(redis_server.url)
    await async_wait_until(lambda: client.get(KEY) == a.token, timeout=ttl_s, what="the holder's token back in Redis")
    # The standby, whose client may have reconnected without noticing, waited a lease's time too.
    await async_wait_until(lambda: client.info("server")["uptime_in_seconds"] > ttl_s, timeout=2 * ttl_s)
    await asyncio.sleep(0.2)
    assert await a.check() and not waiting.done()
    waiting.cancel()
    renewing.cancel()
    await asyncio.gather(waiting, renewing, return_exceptions=True)


async def test_while_redis_is_out_of_reach_the_holder_may_only_stop_the_robot_then_holds_again(leases, redis_server):
    a, b = leases("link-a"), leases("link-b")
    await asyncio.wait_for(a.acquire(), DEADLINE_S)
    renewing = asyncio.ensure_future(a.hold())
    waiting = asyncio.ensure_future(b.acquire())

    redis_server.stop()
    await asyncio.sleep(TTL_S * 1.5)  # past the lease: nobody can prove or take it
    assert not a.held and a.may_stop and not renewing.done()
    assert not await a.check()  # nothing but a stop goes out
    assert not b.may_stop

    redis_server.start()
    await async_wait_until(lambda: a.held, timeout=3 * TTL_S, what="the holder taking its key back")
    assert await a.check() and not waiting.done() and not renewing.done()
    waiting.cancel()
    renewing.cancel()
    await asyncio.gather(waiting, renewing, return_exceptions=True)


async def test_a_holder_that_finds_its_key_taken_when_redis_returns_gives_up(leases, redis_server):
    a = leases("link-a")
    await asyncio.wait_for(a.acquire(), DEADLINE_S)
    renewing = asyncio.ensure_future(a.hold())
    redis_server.stop()
    await asyncio.sleep(TTL_S * 1.5)
    assert a.may_stop
    redis_server.start()
    redis.Redis.from_url(redis_server.url).set(KEY, b"link-b:elsewhere")  # the other link was quicker
    await asyncio.wait_for(renewing, 3 * TTL_S)
    assert a.lost.is_set() and not a.may_stop and not a.held


async def test_a_renewing_holder_ends_when_cancelled_mid_renewal(leases):
    """The link's stop cancels the renewal wherever it is, inside redis-py's commands too (Python 3.11's
    wait_for there lost such a cancellation now and then, and the holder renewed on)."""
    lease = leases("link-a")
    await lease.acquire()
    lease.renew_s = 0  # renewals back to back: each cancel lands in one or between two
    for _ in range(50):
        holding = asyncio.ensure_future(lease.hold())
        await asyncio.sleep(random.random() * 0.005)
        holding.cancel()
        done, _ = await asyncio.wait({holding}, timeout=DEADLINE_S)
        assert done and holding.cancelled(), "the holder renewed on, its stop lost"
