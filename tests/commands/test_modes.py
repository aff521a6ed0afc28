"""The mode commander's pieces: reached-state rules, the lock, the requested-mode broadcast."""

from __future__ import annotations

import pytest

from robot import interface as ri
from robot.commands import modes
from robot.commands.pipeline import Busy
from robot.live import redis_clients
from robot.live.state import redis_key
from tests.commands.support import received, until_the_server_hears, wait_ready
from tests.helpers import async_wait_until, receive_until, ws_communicator


@pytest.mark.parametrize(("mode", "state", "reached"), [
    (ri.Mode.MANUAL, "manual", True),
    (ri.Mode.MANUAL, "suspension", False),
    (ri.Mode.DEMO, "demo", True),
    (ri.Mode.STOP, "suspension", True),
    (ri.Mode.STOP, "startup", False),
    (ri.Mode.BEHAVIOUR, "idle", True),
    (ri.Mode.BEHAVIOUR, "sleeping", True),
    (ri.Mode.BEHAVIOUR, "navigation_planning", True),
    (ri.Mode.BEHAVIOUR, "suspension", False),
    (ri.Mode.BEHAVIOUR, "manual", False),
    (ri.Mode.BEHAVIOUR, "", False),
])
def test_it_counts_behaviours_inner_states_as_behaviour(mode, state, reached):
    assert modes.state_reached(mode, state) is reached


async def test_it_holds_one_mode_change_at_a_time():
    async with modes.serialised(ri.Mode.BEHAVIOUR):
        with pytest.raises(Busy, match="A mode change to behaviour is already in progress"):
            async with modes.serialised(ri.Mode.MANUAL):
                pass
    async with modes.serialised(ri.Mode.MANUAL):  # released: the next one gets it
        pass


async def test_it_lets_the_redis_lock_expire_if_its_holder_dies():
    client = redis_clients.new_aclient()
    try:
        async with modes.serialised(ri.Mode.DEMO):
            ttl_ms = await client.pttl(redis_key(modes.LOCK))
        assert 0 < ttl_ms <= (modes.longest_change_s(ri.Mode.DEMO) + 1) * 1000
        assert await client.exists(redis_key(modes.LOCK)) == 0
    finally:
        await client.aclose()


@pytest.mark.django_db(transaction=True)
async def test_it_shows_every_watcher_the_requested_mode(link, sim, operator, viewer):
    wait_ready(sim)
    await until_the_server_hears(lambda s: s == "suspension", "suspension")
    communicator = ws_communicator(viewer)
    await communicator.connect()
    await communicator.send_json_to({"action": "watch", "keys": [modes.MODE_REQUEST_KEY]})
    outcome = await modes.achange_mode(user=operator, source="websocket", mode=ri.Mode.MANUAL)
    assert outcome == "Manual mode reached (manual): emotion system OFF, manual_start (suspension → manual)"
    frames = []
    await receive_until(communicator, lambda f: f.get("key") == "mode_request" and frames.append(f["msg"]) is None
                        and f["msg"]["status"] == "reached")
    assert [f["status"] for f in frames] == ["running", "reached"]
    assert frames[-1] | {"strategy": None} == {"mode": "manual", "value": "manual control", "target_state": "manual",
                                               "by": "otto", "status": "reached", "error": "", "strategy": None}
    await async_wait_until(lambda: sim.snapshot()["state"]["smach_state"] == "manual", timeout=5)
    await communicator.disconnect()


async def test_it_performs_a_mode_without_role_or_lock_for_the_emergency_stop(link, sim, settings):
    settings.MODE_COMMANDER = "server"
    wait_ready(sim)
    await until_the_server_hears(lambda s: s == "suspension", "suspension")
    await modes.perform_mode(ri.Mode.DEMO)
    async with modes.serialised(ri.Mode.DEMO):  # a mode change in progress does not block it
        await modes.perform_mode(ri.Mode.STOP)
    await async_wait_until(lambda: len(received(sim, "register_event")) == 2, what="both events")
    assert [m["data"] for m in received(sim, "register_event")] == ["demo_start", "aborted"]
    assert received(sim, "emotional_controller") == [{"data": "OFF"}, {"data": "OFF"}]
