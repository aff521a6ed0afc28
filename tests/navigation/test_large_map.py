"""A large map from the robot: decoded on the link's decoding thread, rendered cell for cell."""

import threading

import numpy as np
import pytest

from robot import interface as ri
from robot.link import rosclient
from robot.link.wire import LARGE_FRAME_BYTES
from robot.live.groups import MAP_META_KEY
from robot.live.state import get_store
from robot.navigation.mapimage import grid_path, map_dir
from tests.helpers import async_wait_until

pytestmark = pytest.mark.django_db(transaction=True)


def occupancy_grid(grid: np.ndarray) -> dict:
    height, width = grid.shape
    return {
        "header": {"seq": 0, "stamp": {"secs": 0, "nsecs": 0}, "frame_id": ri.MAP_FRAME},
        "info": {"map_load_time": {"secs": 0, "nsecs": 0}, "resolution": 0.05, "width": width, "height": height,
                 "origin": {"position": {"x": -5.0, "y": -4.0, "z": 0.0},
                            "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}},
        "data": grid.ravel().tolist(),
    }


def map_meta():
    entry = get_store().get_all().get(MAP_META_KEY)
    return entry["msg"] if entry else None


async def test_a_large_map_is_decoded_off_the_event_loop_and_rendered_exactly(link, sim, monkeypatch):
    decoded_on = []
    real_decode = rosclient.decode_frame

    def spy(payload, **kwargs):
        decoded_on.append(threading.current_thread().name)
        return real_decode(payload, **kwargs)

    monkeypatch.setattr(rosclient, "decode_frame", spy)
    await async_wait_until(map_meta, timeout=10, what="the simulator's own map")
    rng = np.random.default_rng(3)
    grid = rng.choice(np.array([-1, 0, 0, 0, 37, 100], dtype=np.int8), size=(900, 1000))
    msg = occupancy_grid(grid)
    assert len(str(msg["data"])) > LARGE_FRAME_BYTES

    sim.call(lambda: sim.robot.bus.publish_name(ri.topic("map").name, msg, latch=True))
    meta = await async_wait_until(lambda: (m := map_meta()) and m["width"] == 1000 and m, timeout=20,
                                  what="the large map to be rendered")

    assert decoded_on and all(name.startswith("rosbridge-decode") for name in decoded_on)
    assert threading.current_thread().name not in decoded_on
    assert (meta["height"], meta["origin"]["x"], meta["origin"]["y"]) == (900, -5.0, -4.0)
    stored = np.load(grid_path(map_dir(), meta["version"]))
    assert np.array_equal(stored, grid)


async def test_a_large_frame_the_link_cannot_decode_is_logged_and_the_link_carries_on(link, sim, caplog):
    await async_wait_until(map_meta, timeout=10, what="the simulator's own map")
    bad = b'{"op":"publish","topic":"/map","msg":{"data":[' + b"1," * LARGE_FRAME_BYTES + b',2]}}'
    proto = link.dial.ros.factory._proto
    from twisted.internet import reactor

    reactor.callFromThread(proto.on_message, bad)
    await async_wait_until(lambda: "undecodable" in caplog.text, timeout=10, what="the decoding error in the log")
    assert link.connected
    before = map_meta()["version"]
    grid = np.zeros((1000, 1100), dtype=np.int8)
    sim.call(lambda: sim.robot.bus.publish_name(ri.topic("map").name, occupancy_grid(grid), latch=True))
    meta = await async_wait_until(lambda: (m := map_meta()) and m["version"] != before and m, timeout=20,
                                  what="the next map after the broken frame")
    assert meta["width"] == 1100
