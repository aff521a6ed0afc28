"""The drive lock on Redis: one holder, refresh/release by the holder only,
admin takeover, e-stop clear, expiry."""

import asyncio
import uuid

import pytest

from robot.live.locks import HeldLock, Holder

OTTO = Holder(owner="chan.otto", username="otto")
OLGA = Holder(owner="chan.olga", username="olga")
OTTO_OTHER_TAB = Holder(owner="chan.otto2", username="otto")


@pytest.fixture
def make_lock():
    def make(ttl_s: float = 30.0):
        return HeldLock(f"test:teleop-lock:{uuid.uuid4().hex}", ttl_s)

    return make


async def test_it_gives_the_lock_to_one_holder_at_a_time(make_lock):
    lock = make_lock()
    assert await lock.acquire(OTTO) == OTTO
    assert await lock.acquire(OLGA) == OTTO
    assert await lock.acquire(OTTO_OTHER_TAB) == OTTO  # a second tab of the same user is another driver
    assert await lock.acquire(OTTO) == OTTO  # re-entrant for the holder
    assert await lock.holder() == OTTO


async def test_it_lets_only_the_holder_refresh_and_release(make_lock):
    lock = make_lock()
    await lock.acquire(OTTO)
    assert await lock.refresh(OLGA) is False
    assert await lock.release(OLGA) is False
    assert await lock.holder() == OTTO
    assert await lock.refresh(OTTO) is True
    assert await lock.release(OTTO) is True
    assert await lock.holder() is None
    assert await lock.acquire(OLGA) == OLGA


async def test_it_hands_the_lock_over_and_clears_it(make_lock):
    lock = make_lock()
    await lock.acquire(OTTO)
    assert await lock.take(OLGA) == OTTO
    assert await lock.holder() == OLGA
    assert await lock.refresh(OTTO) is False
    assert await lock.clear() == OLGA
    assert await lock.holder() is None
    assert await lock.take(OTTO) is None


async def test_it_frees_the_lock_when_the_holder_stops_refreshing(make_lock):
    lock = make_lock(ttl_s=0.3)
    await lock.acquire(OTTO)
    await asyncio.sleep(0.15)
    assert await lock.refresh(OTTO) is True  # a refresh restarts the clock
    await asyncio.sleep(0.2)
    assert await lock.holder() == OTTO
    for _ in range(50):
        if await lock.holder() is None:
            break
        await asyncio.sleep(0.05)
    assert await lock.holder() is None
    assert await lock.acquire(OLGA) == OLGA
