"""The link reaches the robot through the agent's uplink, on loopback (the network boundary: test_netns)."""

from __future__ import annotations

import asyncio
import contextlib
import time

import pytest
from websockets.asyncio.client import connect
from websockets.exceptions import InvalidStatus

from robot.models import AuditEntry
from tests.helpers import async_wait_until
from tests.stack import free_port
from tests.uplink.relay import LatencyRelay

pytestmark = pytest.mark.django_db(transaction=True)


async def _link():
    from robot.link.hosting import start_link

    link, tasks = await start_link(embedded=True, background=False)
    return link, tasks


async def _stop(link, tasks):
    from robot import supervisor

    for task in tasks:
        task.cancel()
    await link.stop()
    supervisor.release(link)


async def _actions(*names: str) -> list[AuditEntry]:
    from asgiref.sync import sync_to_async

    return await sync_to_async(lambda: list(AuditEntry.objects.filter(action__in=names).order_by("id")))()


async def test_it_carries_the_link_to_the_robot(sim, endpoint, credential, agent_for):
    _, text = credential
    agent = agent_for(text)
    await async_wait_until(lambda: endpoint.live is not None, timeout=10, what=f"uplink open\n{agent.log()}")
    link, tasks = await _link()
    try:
        await async_wait_until(lambda: link.connected, timeout=10, what="link connected through the uplink")
        assert link.dial.url == endpoint_url(endpoint)
        before = sim.received_count("/cyborg_audio/text_to_speech")
        reply = await link.requests.execute({"op": "publish", "topic": "/cyborg_audio/text_to_speech",
                                    "msg_type": "std_msgs/String", "msg": {"data": "through the uplink"}})
        assert reply["ok"], reply
        await async_wait_until(lambda: sim.received_count("/cyborg_audio/text_to_speech") > before, timeout=5,
                               what="the robot got the publish")
        status = link.upkeep.status()
        assert status["connected"]
        assert endpoint.status()["connected"] and endpoint.status()["address"] == "127.0.0.1"
        connects = await _actions("uplink.connect")
        assert [e.address for e in connects] == ["127.0.0.1"] and connects[0].ok
    finally:
        await _stop(link, tasks)


def endpoint_url(endpoint) -> str:
    return f"ws://127.0.0.1:{endpoint.relays.rosbridge_port}"


async def test_a_bad_credential_gets_a_closed_door_and_an_audit_row(endpoint, credential):
    _, text = credential
    for header in ({}, {"Authorization": "Bearer cyu_nope_nope"}, {"Authorization": "Bearer " + text + "x"}):
        with pytest.raises(InvalidStatus) as refused:
            async with connect(f"ws://127.0.0.1:{endpoint.port}/uplink/", additional_headers=header):
                pass
        assert refused.value.response.status_code == 403 and not refused.value.response.body
    assert endpoint.live is None
    refusals = await _actions("uplink.refuse")
    assert len(refusals) == 3 and not any(e.ok for e in refusals)


async def test_a_flood_of_attempts_is_throttled(endpoint, settings):
    codes = []
    for _ in range(settings.UPLINK_FAILURE_LIMIT + 3):
        with pytest.raises(InvalidStatus) as refused:
            async with connect(f"ws://127.0.0.1:{endpoint.port}/uplink/",
                               additional_headers={"Authorization": "Bearer cyu_a_b"}):
                pass
        codes.append(refused.value.response.status_code)
    assert codes == [403] * settings.UPLINK_FAILURE_LIMIT + [429] * 3
    assert len(await _actions("uplink.refuse")) == settings.UPLINK_FAILURE_LIMIT  # not one per flooded attempt


async def test_nothing_listens_for_the_link_while_the_robot_is_away(endpoint):
    with pytest.raises(OSError):
        await asyncio.open_connection("127.0.0.1", endpoint.relays.rosbridge_port)


async def test_revoking_the_credential_closes_its_live_uplink_at_once(sim, endpoint, credential, agent_for):
    from asgiref.sync import sync_to_async

    from robot.uplink.credentials import credential_revoke

    made, text = credential
    agent = agent_for(text)
    await async_wait_until(lambda: endpoint.live is not None, timeout=10, what=f"uplink open\n{agent.log()}")
    await sync_to_async(credential_revoke)(credential=made)
    await async_wait_until(lambda: endpoint.live is None, what="the revoked uplink closed")
    gone: list = []
    for _ in range(250):  # the audit row follows the close (the audit writer's thread)
        if gone := await _actions("uplink.disconnect"):
            break
        await asyncio.sleep(0.02)
    assert len(gone) == 1 and "revoked" in gone[0].outcome
    await async_wait_until(lambda: "the server refused the uplink" in agent.log(), timeout=5, what="a refusal")
    assert endpoint.live is None


async def test_it_dials_through_an_http_proxy(sim, endpoint, credential, agent_for):
    """A proxy that allows CONNECT (a campus network's), here a small one of the test's own."""
    tunnels: list[str] = []

    async def proxy(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        head = await reader.readuntil(b"\r\n\r\n")
        target = head.split(b" ")[1].decode()
        tunnels.append(target)
        host, port = target.rsplit(":", 1)
        up_reader, up_writer = await asyncio.open_connection(host, int(port))
        writer.write(b"HTTP/1.1 200 Connection established\r\n\r\n")

        async def pipe(src: asyncio.StreamReader, dst: asyncio.StreamWriter) -> None:
            while chunk := await src.read(65536):
                dst.write(chunk)
                await dst.drain()
            dst.close()

        await asyncio.gather(pipe(reader, up_writer), pipe(up_reader, writer), return_exceptions=True)

    server = await asyncio.start_server(proxy, "127.0.0.1", 0)
    port = server.sockets[0].getsockname()[1]
    try:
        agent = agent_for(credential[1], UPLINK_PROXY=f"http://127.0.0.1:{port}")
        await async_wait_until(lambda: endpoint.live is not None, timeout=10, what=f"uplink open\n{agent.log()}")
        assert tunnels == [f"127.0.0.1:{endpoint.port}"]
    finally:
        server.close()


def _twist(x: float) -> dict:
    return {"op": "publish", "topic": "/cmd_vel", "msg_type": "geometry_msgs/Twist",
            "msg": {"linear": {"x": x, "y": 0.0, "z": 0.0}, "angular": {"x": 0.0, "y": 0.0, "z": 0.0}}}


async def _drive(link, x: float, seconds: float) -> None:
    """A press from rest, then the teleop rate (20 Hz) of Twists of forward speed ``x``, for ``seconds``."""
    end = time.monotonic() + seconds
    first = True
    while time.monotonic() < end:
        reply = await link.requests.execute({**_twist(x), "fresh_press": first})
        first = False
        assert reply["ok"], reply
        await asyncio.sleep(0.05)


def _speeds_since(sim, count: int) -> list[float]:
    new = sim.received_count("/cmd_vel") - count
    return [m["linear"]["x"] for m in sim.received("/cmd_vel")[-new:]] if new > 0 else []


@contextlib.asynccontextmanager
async def _through_a_relay(endpoint, credential, agent_for):
    """An agent dialling ``endpoint`` through a relay the test can freeze or cut, and a link through it."""
    _, text = credential
    relay = LatencyRelay(("127.0.0.1", free_port()), (endpoint.host, endpoint.port))
    agent = agent_for(text, UPLINK_SERVER_URL=f"ws://127.0.0.1:{relay.listen[1]}/uplink/")
    await async_wait_until(lambda: endpoint.live is not None, timeout=10, what=f"uplink open\n{agent.log()}")
    link, tasks = await _link()
    try:
        await async_wait_until(lambda: link.connected, timeout=10, what="link connected through the uplink")
        yield relay, agent, link
    finally:
        await _stop(link, tasks)
        relay.close()


async def test_drive_commands_held_up_in_a_frozen_uplink_never_reach_the_robot(sim, endpoint, credential,
                                                                               agent_for):
    """A frozen uplink thaws with what waited in it: the agent stops the robot during the freeze and
    drops the Twists that waited past its deadman time, and a fresh one after the thaw drives again."""
    async with _through_a_relay(endpoint, credential, agent_for) as (relay, agent, link):
        before = sim.received_count("/cmd_vel")
        await _drive(link, 0.3, 0.4)
        await async_wait_until(lambda: 0.3 in _speeds_since(sim, before), timeout=5, what="driving at the robot")
        relay.frozen = True
        frozen_at = sim.received_count("/cmd_vel")
        await _drive(link, 0.2, 0.5)  # the operator holds the key; nothing gets through
        # The agent's deadman: its zero, on its own session to the robot.
        await async_wait_until(lambda: 0.0 in _speeds_since(sim, frozen_at), timeout=5, what="the agent's zero")
        await asyncio.sleep(0.6)  # the oldest waited Twist is now over a second old, the newest 0.6 s
        thawed_at = sim.received_count("/cmd_vel")
        relay.frozen = False
        await _drive(link, 0.1, 0.4)
        await async_wait_until(lambda: 0.1 in _speeds_since(sim, thawed_at), timeout=5, what="driving again")
        assert 0.2 not in _speeds_since(sim, thawed_at), "a Twist held up in the freeze reached the robot"
        assert "dropped a drive command" in agent.log()


async def test_a_key_held_through_an_uplink_blip_moves_nothing_until_released(sim, endpoint, credential, agent_for):
    """The uplink drops for a moment while a driver holds a key: after the agent redials, the held key's
    Twists are refused (the driver is told to let go), and a release followed by a press drives again."""
    async with _through_a_relay(endpoint, credential, agent_for) as (relay, agent, link):
        before = sim.received_count("/cmd_vel")
        await _drive(link, 0.3, 0.3)
        await async_wait_until(lambda: 0.3 in _speeds_since(sim, before), timeout=5, what="driving at the robot")
        relay.cut()  # the blip: the agent stops the robot and redials
        await async_wait_until(lambda: not link.connected, timeout=10, what="the link noticing the blip")
        await async_wait_until(lambda: link.connected, timeout=15, what=f"the uplink back\n{agent.log()}")
        back_at = sim.received_count("/cmd_vel")
        refusals = []
        end = time.monotonic() + 1.0
        while time.monotonic() < end:  # the key is still held
            reply = await link.requests.execute(_twist(0.3))
            refusals.append(reply.get("error_code"))
            await asyncio.sleep(0.05)
        assert set(refusals) == {"release_first"}, refusals
        assert not any(_speeds_since(sim, back_at)), "the held key moved the robot after the blip"
        assert (await link.requests.execute(_twist(0.0)))["ok"]  # let go …
        await _drive(link, 0.2, 0.3)  # … and press again
        await async_wait_until(lambda: 0.2 in _speeds_since(sim, back_at), timeout=5, what="driving again")
