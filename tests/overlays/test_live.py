"""Against the simulator: each overlay reaches a watching page placed on the map, costmaps as tiles."""

import asyncio
import io
import math

import numpy as np
import pytest
from asgiref.sync import sync_to_async
from django.test import Client
from PIL import Image

from robot import interface as ri
from robot.live.groups import (
    OVERLAY_FOOTPRINT_KEY,
    OVERLAY_GLOBAL_COSTMAP_KEY,
    OVERLAY_LOCAL_COSTMAP_KEY,
    OVERLAY_LOCAL_PLAN_KEY,
    OVERLAY_PARTICLES_KEY,
    OVERLAY_SCAN_KEY,
)
from robot.live.keys import OVERLAY_SOURCES
from robot.overlays.link import overlays
from simulator.world import OCCUPIED
from tests.conftest import EITHER_ROS
from tests.helpers import async_wait_until, receive_until, ws_communicator

pytestmark = pytest.mark.django_db(transaction=True)


@pytest.fixture
async def overlay_link(link, sim):
    assert overlays.listen in link.listeners  # from the link's start: the latched /tf_static comes once
    await async_wait_until(lambda: link.dial.ros_version == sim.robot.ros, timeout=10, what="the link to find the ROS")
    yield link


async def watching(user, keys):
    ws = ws_communicator(user)
    connected, _ = await ws.connect()
    assert connected
    await ws.send_json_to({"action": "watch", "keys": keys})
    return ws


def update_of(key, ok=lambda msg: True):
    return lambda f: f.get("kind") == "update" and f["key"] == key and ok(f["msg"])


def near_occupied(world, x, y, cells=1):
    r, c = world.cell(x, y)
    block = world.grid[max(r - cells, 0):r + cells + 1, max(c - cells, 0):c + cells + 1]
    return bool((block >= OCCUPIED).any())


def placed(msg):
    return "points" in msg and not msg.get("problem")


@EITHER_ROS
async def test_the_laser_overlay_lands_on_the_walls_the_robot_sees(overlay_link, sim, viewer):
    ws = await watching(viewer, [OVERLAY_SCAN_KEY])
    try:
        frame = await receive_until(ws, update_of(OVERLAY_SCAN_KEY, placed), timeout=20)
        msg = frame["msg"]
        points = np.array(msg["points"]).reshape(-1, 2)
        assert msg["beams"] == 541 and len(points) > 300
        world = sim.robot.world
        on_walls = [near_occupied(world, x, y) for x, y in points]
        assert all(on_walls), f"{on_walls.count(False)} of {len(points)} points are off the walls"
        b = sim.robot.base  # the laser sits 0.2 m ahead of the base
        assert msg["origin"] == pytest.approx([b.x + 0.2 * math.cos(b.yaw), b.y + 0.2 * math.sin(b.yaw)], abs=0.02)
        assert sim.subscription_count(ri.topic("scan").name) == 1
    finally:
        await ws.disconnect()


@EITHER_ROS
async def test_two_pages_share_one_subscription_and_unwatching_stops_the_frames(overlay_link, sim, viewer, operator):
    pages = [await watching(u, [OVERLAY_PARTICLES_KEY, OVERLAY_FOOTPRINT_KEY]) for u in (viewer, operator)]
    try:
        for ws in pages:
            cloud = (await receive_until(ws, update_of(OVERLAY_PARTICLES_KEY, lambda m: "poses" in m), timeout=10))
            poses = np.array(cloud["msg"]["poses"]).reshape(-1, 3)
            b = sim.robot.base
            assert len(poses) == cloud["msg"]["count"] == 300
            assert abs(np.median(poses[:, 0]) - b.x) < 0.5 and abs(np.median(poses[:, 1]) - b.y) < 0.5
            footprint = await receive_until(ws, update_of(OVERLAY_FOOTPRINT_KEY, placed), timeout=10)
            corners = np.array(footprint["msg"]["points"]).reshape(-1, 2)
            assert len(corners) == 4 and np.allclose(corners.mean(axis=0), [b.x, b.y], atol=0.05)
        assert sim.subscription_count(ri.topic("particlecloud").name) == 1
        await pages[0].send_json_to({"action": "unwatch", "keys": [OVERLAY_PARTICLES_KEY, OVERLAY_FOOTPRINT_KEY]})
        await asyncio.sleep(0.3)
        while not await pages[0].receive_nothing(timeout=0.05):
            await pages[0].receive_from()  # what was already under way
        kinds = set()
        deadline = asyncio.get_running_loop().time() + 1.5  # particles come at 2 Hz, the footprint at 5 Hz
        while asyncio.get_running_loop().time() < deadline:
            if not await pages[0].receive_nothing(timeout=0.1):
                kinds.add((await pages[0].receive_json_from())["kind"])
        assert kinds <= {"status"}  # link status frames only
        await receive_until(pages[1], update_of(OVERLAY_PARTICLES_KEY), timeout=5)  # the other page still gets them
    finally:
        for ws in pages:
            await ws.disconnect()


@EITHER_ROS
async def test_overlay_subscriptions_go_upstream_once_the_last_page_lets_go(overlay_link, sim, viewer, operator,
                                                                            settings):
    settings.TOPICS_IDLE_GRACE_S = 0.3

    def sources(*keys):  # what the link subscribes to only for pages that show these overlays
        return {ri.topic(t).name for key in keys for t in OVERLAY_SOURCES[key] if not ri.topic(t).monitor}

    def subscribed_exactly(names):
        return lambda: all(sim.subscription_count(n) == (1 if n in names else 0) for n in everything)

    shown = [OVERLAY_SCAN_KEY, OVERLAY_PARTICLES_KEY, OVERLAY_LOCAL_COSTMAP_KEY, OVERLAY_FOOTPRINT_KEY]
    everything = sources(*shown, OVERLAY_LOCAL_PLAN_KEY)
    first = await watching(viewer, shown)
    second = await watching(operator, [OVERLAY_LOCAL_PLAN_KEY])
    await async_wait_until(subscribed_exactly(everything), timeout=10, what="one subscription per source")
    await first.send_json_to({"action": "unwatch", "keys": [OVERLAY_SCAN_KEY]})
    await async_wait_until(subscribed_exactly(everything - {ri.topic("scan").name}), timeout=5, what="scan let go")
    await first.disconnect()
    # The other page's local plan still needs its path and the transforms, the footprint shared with it.
    await async_wait_until(subscribed_exactly(sources(OVERLAY_LOCAL_PLAN_KEY)), timeout=5, what="the first page's")
    await second.send_json_to({"action": "unwatch", "keys": [OVERLAY_LOCAL_PLAN_KEY]})
    await async_wait_until(subscribed_exactly(set()), timeout=5, what="every overlay source let go")
    assert sim.subscription_count(ri.topic("robot_pose").name) == 1  # the registry's own stay
    await second.send_json_to({"action": "watch", "keys": [OVERLAY_PARTICLES_KEY]})  # and back on demand
    await receive_until(second, update_of(OVERLAY_PARTICLES_KEY, lambda m: "poses" in m), timeout=10)
    await second.disconnect()
    await async_wait_until(subscribed_exactly(set()), timeout=5, what="let go when the page closed")


async def fetch_tile(user, meta, row, col):
    client = Client()
    await sync_to_async(client.force_login)(user)
    rev = meta["tiles"][row][col]
    response = await sync_to_async(client.get)(f"{meta['url']}{row}-{col}-{rev}.png")
    assert response.status_code == 200, response.status_code
    assert "immutable" in response["Cache-Control"]
    return np.array(Image.open(io.BytesIO(b"".join(response.streaming_content))))


@EITHER_ROS
async def test_the_global_costmap_is_served_as_tiles_and_an_update_patches_its_tile(overlay_link, sim, viewer):
    ws = await watching(viewer, [OVERLAY_GLOBAL_COSTMAP_KEY])
    try:
        meta = (await receive_until(ws, update_of(OVERLAY_GLOBAL_COSTMAP_KEY), timeout=15))["msg"]
        world = sim.robot.world
        assert (meta["width"], meta["height"], meta["frame"]) == (world.width, world.height, "map")
        assert meta["origin"] == {"x": world.origin_x, "y": world.origin_y, "yaw": 0.0}
        tile = await fetch_tile(viewer, meta, 0, 0)
        # walls are lethal, free space next to them inflated, the open hall free, outside unknown (-1)
        flipped = np.flipud(tile.astype(np.int8))[:world.height, :world.width]
        assert (flipped[world.grid >= OCCUPIED] == 100).all()
        r, c = world.cell(0.0, -1.0)
        assert flipped[r, c] == 0 and flipped[0, 0] == -1
        assert ((flipped > 0) & (flipped < 99)).sum() > 1000
        # an update in the unknown corner, far from the robot's own updates
        sim.robot.publish_external(ri.topic("global_costmap_updates").name, {
            "header": {"frame_id": "map"}, "x": 0, "y": 0, "width": 2, "height": 1, "data": [100, 42]})
        # The robot's own updates may patch the same tile first (a loaded machine delays ours): the
        # tile's revisions until ours has landed.
        seen = meta
        for _ in range(20):
            seen = (await receive_until(ws, update_of(
                OVERLAY_GLOBAL_COSTMAP_KEY, lambda m, rev=seen["tiles"][0][0]: m["tiles"][0][0] > rev),
                timeout=10))["msg"]
            assert seen["version"] == meta["version"]
            tile = await fetch_tile(viewer, seen, 0, 0)
            if tile[world.height - 1, 0:2].tolist() == [100, 42]:
                break
        assert tile[world.height - 1, 0:3].tolist() == [100, 42, 255]
    finally:
        await ws.disconnect()


@EITHER_ROS
async def test_the_local_costmap_is_placed_on_the_map_through_odometry(overlay_link, sim, viewer):
    ws = await watching(viewer, [OVERLAY_LOCAL_COSTMAP_KEY])
    try:
        meta = (await receive_until(ws, update_of(OVERLAY_LOCAL_COSTMAP_KEY, lambda m: m["origin"]), timeout=15))["msg"]
        assert meta["frame"] == "odom" and meta["width"] == meta["height"] == 80
        tile = np.flipud(await fetch_tile(viewer, meta, 0, 0)).astype(np.int8)
        world, o, res = sim.robot.world, meta["origin"], meta["resolution"]
        c, s = math.cos(o["yaw"]), math.sin(o["yaw"])
        lethal = np.argwhere(tile == 100)
        assert len(lethal) > 0  # the start pose is 2.5 m from a pillar row
        for row, col in lethal:
            u, v = (col + 0.5) * res, (row + 0.5) * res
            assert near_occupied(world, o["x"] + c * u - s * v, o["y"] + s * u + c * v)
    finally:
        await ws.disconnect()


@EITHER_ROS
async def test_a_page_is_told_why_an_overlay_cannot_be_placed(overlay_link, sim, viewer):
    name = ri.topic("local_plan").name  # the simulator publishes none while the robot stands
    ws = await watching(viewer, [OVERLAY_LOCAL_PLAN_KEY])
    try:
        await async_wait_until(lambda: sim.subscription_count(name) == 1, timeout=5)
        sim.robot.publish_external(name, {"header": {"frame_id": "nowhere"}, "poses": []})
        frame = await receive_until(ws, update_of(OVERLAY_LOCAL_PLAN_KEY), timeout=10)
        assert "nowhere" in frame["msg"]["problem"] and "points" not in frame["msg"]
    finally:
        await ws.disconnect()
