"""Everyone watching the map sees the same map version, goal, goal status and named locations."""

import asyncio

import pytest
from asgiref.sync import sync_to_async

from robot.live.groups import GOAL_KEY, GOAL_STATUS_KEY, LOCATIONS_KEY, MAP_META_KEY
from robot.live.state import get_store
from robot.models import Location
from robot.navigation.goals import agoal_send
from robot.navigation.handlers import track_goal_statuses
from tests.helpers import async_wait_until, receive_until, ws_communicator

pytestmark = pytest.mark.django_db(transaction=True)


async def watching(user, keys):
    communicator = ws_communicator(user)
    connected, _ = await communicator.connect()
    assert connected
    await communicator.send_json_to({"action": "watch", "keys": keys})
    return communicator


def is_update(key):
    return lambda frame: frame.get("kind") == "update" and frame["key"] == key


async def test_it_shows_every_watcher_the_same_goal_and_its_status(link, operator, viewer):
    tracker = asyncio.ensure_future(track_goal_statuses(link))
    await async_wait_until(lambda: get_store().get_all().get(MAP_META_KEY), timeout=10, what="the map")
    watchers = [await watching(u, [MAP_META_KEY, GOAL_KEY, GOAL_STATUS_KEY]) for u in (viewer, operator)]
    try:
        for ws in watchers:  # the map is announced to pages opened after it arrived
            frame = await receive_until(ws, is_update(MAP_META_KEY))
            assert frame["msg"]["image_url"].endswith(".png")
        goal = await agoal_send(user=operator, source="websocket", data={"x": 1.0, "y": -2.0, "yaw": 0.0})
        for ws in watchers:
            frame = await receive_until(ws, is_update(GOAL_KEY))
            assert frame["msg"]["id"] == goal["id"] and frame["msg"]["by"] == "otto"
            status = await receive_until(
                ws, lambda f: is_update(GOAL_STATUS_KEY)(f) and goal["id"] in f["msg"]["goals"], timeout=10)
            assert status["msg"]["goals"][goal["id"]]["state"] in ("active", "succeeded")
    finally:
        tracker.cancel()
        for ws in watchers:
            await ws.disconnect()


async def test_it_tells_every_watcher_when_locations_change(operator_api, operator, viewer):
    watchers = [await watching(u, [LOCATIONS_KEY]) for u in (viewer, operator)]
    for ws in watchers:  # frames are handled in order: once this is refused, the watch above is in force
        await ws.send_json_to({"action": "watch", "keys": ["no-such-key"]})
        await receive_until(ws, lambda f: f["kind"] == "error")

    def names(frame):
        return [loc["name"] for loc in frame["msg"]["locations"]]

    try:
        res = await sync_to_async(operator_api.post)(
            "/api/locations/", {"name": "lab", "x": 1.5, "y": -2.0, "yaw": 0.5}, format="json")
        assert res.status_code == 201
        for ws in watchers:
            frame = await receive_until(ws, is_update(LOCATIONS_KEY))
            assert frame["msg"]["locations"] == [{"name": "lab", "map_name": "", "x": 1.5, "y": -2.0, "yaw": 0.5,
                                                 "threshold": 0.5, "description": ""}]
        # The admin and the shell save models directly: the same signal tells the pages.
        await sync_to_async(Location.objects.create)(name="cafe", x=3.0, y=1.0)
        for ws in watchers:
            assert names(await receive_until(ws, is_update(LOCATIONS_KEY))) == ["cafe", "lab"]
        assert (await sync_to_async(operator_api.delete)("/api/locations/lab/")).status_code == 204
        for ws in watchers:
            assert names(await receive_until(ws, is_update(LOCATIONS_KEY))) == ["cafe"]
    finally:
        for ws in watchers:
            await ws.disconnect()
