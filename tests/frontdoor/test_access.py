"""Who gets in through the front door and what is written down: tickets (once, briefly, nothing
else), revocation closing a tool's socket within a second, audit of connects, refusals and the
admin's allowlist; with Channels' communicator against the full application and the simulator."""

from __future__ import annotations

import asyncio
import json
from datetime import timedelta

import pytest
from channels.db import database_sync_to_async
from django.contrib.auth.models import Group
from django.utils import timezone

from cyborg_site.roles import Role
from robot import interface as ri
from robot.frontdoor.tickets import ticket_issue, ticket_redeem
from robot.models import AuditEntry, ConnectTicket, FrontDoorAllowance
from tests.helpers import ws_communicator
from tests.teleop.support import is_moving, is_zero, twists, wait_twist

pytestmark = pytest.mark.django_db(transaction=True)
CMD_VEL = ri.topic("cmd_vel").name


async def door(user, *, ticket: str | None = None):
    raw = ticket if ticket is not None else await database_sync_to_async(ticket_issue)(user=user)
    communicator = ws_communicator(None, f"/rosbridge/?ticket={raw}")
    communicator.scope["client"] = ("192.0.2.7", 50123)
    connected, _ = await communicator.connect(timeout=10)
    return communicator, connected


async def frame_where(communicator, predicate, timeout: float = 10.0) -> dict:
    async with asyncio.timeout(timeout):
        while True:
            frame = json.loads(await communicator.receive_from(timeout=timeout))
            if predicate(frame):
                return frame


async def closed_with(communicator, code: int, within_s: float = 1.0) -> None:
    async with asyncio.timeout(within_s):
        while True:
            message = await communicator.output_queue.get()
            if message["type"] == "websocket.close":
                assert message.get("code") == code, message
                return


def test_a_ticket_works_once_and_not_after_it_expires(operator):
    raw = ticket_issue(user=operator)
    assert ticket_redeem(raw) == operator
    assert ticket_redeem(raw) is None
    late = ticket_issue(user=operator)
    ConnectTicket.objects.update(expires=timezone.now() - timedelta(seconds=1))
    assert ticket_redeem(late) is None
    assert ticket_redeem("") is None and ticket_redeem("made-up") is None


def test_a_deactivated_persons_ticket_lets_nobody_in(operator):
    raw = ticket_issue(user=operator)
    operator.is_active = False
    operator.save()
    assert ticket_redeem(raw) is None


def test_the_api_gives_a_ticket_to_a_token_or_a_session(operator_api, anon_api):
    answer = operator_api.post("/api/frontdoor/ticket/").json()
    assert answer["url"].startswith("ws://") and answer["url"].endswith(answer["ticket"])
    assert "/rosbridge/?ticket=" in answer["url"] and answer["expires_s"] > 0
    assert anon_api.post("/api/frontdoor/ticket/").status_code == 401


async def test_a_socket_without_a_valid_ticket_is_refused_even_with_a_session(operator):
    communicator, connected = await door(operator, ticket="not-a-ticket")
    assert not connected
    communicator = ws_communicator(operator, "/rosbridge/")  # signed in, but no ticket
    connected, _ = await communicator.connect(timeout=10)
    assert not connected


async def test_connects_and_disconnects_are_audited_with_person_and_address(link, viewer):
    communicator, connected = await door(viewer)
    assert connected
    await communicator.disconnect()

    def entries() -> list[tuple[str, str, str]]:
        return list(AuditEntry.objects.filter(source="frontdoor").values_list("action", "username", "address"))

    for _ in range(100):
        found = await database_sync_to_async(entries)()
        if len(found) >= 2:
            break
        await asyncio.sleep(0.05)
    assert sorted(a for a, _, _ in found) == ["frontdoor.connect", "frontdoor.disconnect"]
    assert all(user == viewer.username and address == "192.0.2.7" for _, user, address in found)


async def test_demoting_an_operator_stops_their_tool_and_closes_it_within_a_second(link, sim, operator):
    communicator, connected = await door(operator)
    assert connected
    before = len(await twists(sim))
    for _ in range(5):
        await communicator.send_json_to({"op": "publish", "topic": CMD_VEL,
                                         "msg": {"linear": {"x": 0.2}, "angular": {"z": 0.0}}})
        await asyncio.sleep(0.05)
    await wait_twist(sim, is_moving, after=before, what="driving through the front door")

    def demote() -> None:
        operator.groups.set([Group.objects.get(name=Role.VIEWER)])

    moving_at = len(await twists(sim))
    await database_sync_to_async(demote)()
    await closed_with(communicator, 4403)
    await wait_twist(sim, is_zero, after=moving_at, what="the zero after the revocation")


async def test_an_operator_may_publish_an_allowlisted_topic_through_the_pipeline_and_nothing_else(link, sim, operator):
    await database_sync_to_async(FrontDoorAllowance.objects.create)(kind="topic", name="/lab/beacon")
    communicator, connected = await door(operator)
    assert connected
    await communicator.send_json_to({"op": "advertise", "topic": "/lab/beacon", "type": "std_msgs/String"})
    await communicator.send_json_to({"op": "publish", "topic": "/lab/beacon", "msg": {"data": "hello"}})
    await communicator.send_json_to({"op": "publish", "topic": "/lab/other", "msg": {"data": "no"}, "id": "p2"})
    refused = await frame_where(communicator, lambda f: f.get("op") == "status")
    assert refused["level"] == "error" and "/lab/other" in refused["msg"] and refused["id"] == "p2"
    for _ in range(100):
        if sim.received("/lab/beacon"):
            break
        await asyncio.sleep(0.05)
    assert [m["data"] for m in sim.received("/lab/beacon")] == ["hello"]
    assert not sim.received("/lab/other")
    entry = await database_sync_to_async(AuditEntry.objects.filter(action="frontdoor.publish").get)()
    assert entry.ok and entry.username == operator.username and entry.params["topic"] == "/lab/beacon"
    await communicator.disconnect()


async def test_speech_through_the_front_door_is_the_pages_command(link, sim, operator, viewer):
    topic = ri.topic("text_to_speech").name
    communicator, _ = await door(operator)
    await communicator.send_json_to({"op": "publish", "topic": topic, "msg": {"data": "hello there"}})
    for _ in range(100):
        if sim.received(topic):
            break
        await asyncio.sleep(0.05)
    assert [m["data"] for m in sim.received(topic)] == ["hello there"]
    entry = await database_sync_to_async(AuditEntry.objects.filter(action="speech").get)()
    assert entry.source == "frontdoor" and entry.ok
    await communicator.disconnect()
    watcher, _ = await door(viewer)
    await watcher.send_json_to({"op": "call_service", "service": ri.service("enable_motors").name, "id": "m"})
    answer = await frame_where(watcher, lambda f: f.get("op") == "service_response")
    assert answer["result"] is False and answer["id"] == "m" and "viewers" in answer["values"]
    await watcher.disconnect()


async def test_a_client_asking_fragments_gets_each_message_in_fragments_it_can_join(link, viewer):
    topic = ri.topic("odom").name
    communicator, _ = await door(viewer)
    await communicator.send_json_to({"op": "subscribe", "topic": topic, "fragment_size": 100, "id": "s"})
    first = await frame_where(communicator, lambda f: f.get("op") == "fragment" and f["num"] == 0)
    parts = [first] + [await frame_where(communicator, lambda f: f.get("op") == "fragment")
                       for _ in range(first["total"] - 1)]
    assert [part["num"] for part in parts] == list(range(first["total"])) and {p["id"] for p in parts} == {first["id"]}
    message = json.loads("".join(part["data"] for part in parts))
    assert message["op"] == "publish" and message["topic"] == topic and "pose" in message["msg"]
    await communicator.send_json_to({"op": "unsubscribe", "topic": topic, "id": "s"})
    await communicator.send_json_to({"op": "subscribe", "topic": "not a name", "id": "bad"})
    refused = await frame_where(communicator, lambda f: f.get("op") == "status")
    assert refused["id"] == "bad" and refused["level"] == "error"
    await communicator.disconnect()


def test_the_connect_page_loads_roslibjs_and_its_script_for_anyone_signed_in(client, viewer):
    client.force_login(viewer)
    page = client.get("/rosbridge-tools/").content.decode()
    assert "vendor/roslib/roslib.min.js" in page and "js/frontdoor.js" in page and "/api/frontdoor/ticket/" in page


async def test_a_navigation_goal_from_a_tool_is_the_pages_goal_command(link, sim, operator):
    goal_topic = ri.action_topic("move_base", "goal")[0]
    here = (await asyncio.to_thread(sim.snapshot))["state"]["pose"]
    communicator, _ = await door(operator)
    await asyncio.sleep(1.0)  # the map has arrived at the link (goals are checked against it)
    await communicator.send_json_to({"op": "publish", "topic": ri.topic("move_base_simple_goal").name, "msg": {
        "header": {"frame_id": "map"},
        "pose": {"position": {"x": here["x"], "y": here["y"], "z": 0.0},
                 "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}}})
    for _ in range(200):
        if sim.received(goal_topic):
            break
        await asyncio.sleep(0.05)
    goal = sim.received(goal_topic)[-1]["goal"]["target_pose"]["pose"]["position"]
    assert (goal["x"], goal["y"]) == pytest.approx((here["x"], here["y"]), abs=1e-6)
    entry = await database_sync_to_async(AuditEntry.objects.filter(action="navigation.goal").get)()
    assert entry.source == "frontdoor" and entry.ok, entry.outcome
    await communicator.disconnect()
