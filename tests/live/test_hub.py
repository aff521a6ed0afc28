"""The live hub: updates serialised once, a latest-value slot per key per socket, one frame per tick."""

import asyncio
import json

import pytest

from robot.live import feed, frames, redis_clients
from robot.live.announce import aannounce, apublish_state, server_update
from robot.live.hub import Hub, get_hub
from tests.helpers import async_wait_until, receive_until, ws_communicator

pytestmark = pytest.mark.django_db(transaction=True)


class Recorder:
    """A socket's writes, as the browser would parse them."""

    def __init__(self) -> None:
        self.frames: list[dict] = []

    async def send(self, text: str) -> None:
        self.frames.append(json.loads(text))

    def updates(self) -> list[dict]:
        return [u for f in self.frames if f["kind"] == "updates" for u in f["updates"]]


def fragment(key: str, value, t: float) -> str:
    return frames.update_fragment({"key": key, "msg": {"data": value}, "t": t})


async def test_a_socket_gets_one_frame_per_tick_with_only_the_newest_value_of_each_key():
    hub = Hub(asyncio.get_running_loop(), tick_s=0.05)
    recorder = Recorder()
    socket = hub.attach(recorder.send)
    hub.watch(socket, ["odom", "battery_soc"])
    for i in range(20):  # far faster than the tick: a slow socket's backlog never grows
        hub.publish("odom", fragment("odom", i, 100 + i), 100 + i)
    hub.publish("battery_soc", fragment("battery_soc", 0.5, 200), 200)
    hub.publish("plan", fragment("plan", 1, 201), 201)  # nobody watches it
    await async_wait_until(lambda: recorder.frames)
    await asyncio.sleep(0.15)
    assert len(recorder.frames) == 1
    assert {u["key"]: u["msg"]["data"] for u in recorder.updates()} == {"odom": 19, "battery_soc": 0.5}


async def test_event_like_keys_keep_every_message_in_order_up_to_a_bound():
    hub = Hub(asyncio.get_running_loop())
    recorder = Recorder()
    socket = hub.attach(recorder.send)
    hub.watch(socket, ["rosout"])
    for i in range(5):
        hub.publish("rosout", fragment("rosout", f"line {i}", 100 + i), 100 + i, every=True)
    await async_wait_until(lambda: len(recorder.updates()) == 5)
    assert [u["msg"]["data"] for u in recorder.updates()] == [f"line {i}" for i in range(5)]

    from robot.live.hub import MAX_PENDING

    for i in range(MAX_PENDING + 10):  # a socket far behind drops the oldest and counts them
        socket.offer("rosout", fragment("rosout", i, i), i, every=True)
    assert len(socket.pending) == MAX_PENDING and socket.dropped == 10


async def test_a_socket_that_left_gets_nothing_and_is_forgotten():
    hub = Hub(asyncio.get_running_loop())
    stays, leaves = Recorder(), Recorder()
    kept, gone = hub.attach(stays.send), hub.attach(leaves.send)
    hub.watch(kept, ["odom"])
    hub.watch(gone, ["odom"])
    hub.detach(gone)
    hub.publish("odom", fragment("odom", 1, 1), 1)
    await async_wait_until(lambda: stays.frames)
    assert not leaves.frames
    assert hub.sockets == {kept} and hub._watchers == {"odom": {kept}}


async def test_many_watchers_cost_one_serialisation_per_update(viewer, monkeypatch):
    calls = []
    real = feed.update_fragment
    monkeypatch.setattr(feed, "update_fragment", lambda update: calls.append(update["key"]) or real(update))
    communicators = [ws_communicator(viewer) for _ in range(20)]
    for communicator in communicators:
        assert (await communicator.connect(timeout=10))[0]
        await receive_until(communicator, lambda f: f["kind"] == "status")
        await communicator.send_json_to({"action": "watch", "keys": ["mode_request"]})
    await async_wait_until(lambda: len(get_hub()._watchers.get("mode_request", ())) == 20, timeout=5)
    calls.clear()
    await apublish_state("mode_request", {"mode": "manual"})
    for communicator in communicators:
        frame = await receive_until(communicator, lambda f: f["kind"] == "update")
        assert frame["key"] == "mode_request" and frame["msg"] == {"mode": "manual"}
        await communicator.disconnect()
    assert calls == ["mode_request"]
    assert not get_hub().sockets


async def test_updates_of_one_tick_reach_a_browser_in_one_frame(viewer):
    communicator = ws_communicator(viewer)
    assert (await communicator.connect(timeout=10))[0]
    await receive_until(communicator, lambda f: f["kind"] == "status")
    await communicator.send_json_to({"action": "watch", "keys": ["nav_goal", "nav_goal_status"]})
    await async_wait_until(lambda: len(get_hub()._watchers.get("nav_goal_status", ())) == 1, timeout=5)
    # Into the hub in one loop turn, as the link (embedded) or one Redis read (scaled) delivers them:
    # how far apart two Redis messages arrive is up to the machine's load.
    for key, msg in (("nav_goal", {"x": 1}), ("nav_goal_status", {"status": "active"})):
        update = server_update(key, msg)
        get_hub().publish(key, frames.update_fragment(update), update["t"])
    frame = await communicator.receive_json_from(timeout=5)
    assert frame["kind"] == "updates"
    assert {u["key"] for u in frame["updates"]} == {"nav_goal", "nav_goal_status"}
    await communicator.disconnect()


async def test_the_first_snapshot_never_replaces_a_newer_live_value(viewer, monkeypatch):
    from robot.live.state import get_store

    store = get_store()
    await store.aput("nav_goal", dict(server_update("nav_goal", {"x": "stored"}, t=100.0)))
    communicator = ws_communicator(viewer)
    assert (await communicator.connect(timeout=10))[0]
    await receive_until(communicator, lambda f: f["kind"] == "status")
    read = store.aget_many

    async def read_then_a_newer_value_arrives(keys):
        entries = await read(keys)
        await aannounce("nav_goal", dict(server_update("nav_goal", {"x": "live"}, t=200.0)), keep=False)
        return entries

    # The process's one subscription must be up to hear the live value.
    client = redis_clients.client()
    await async_wait_until(lambda: client.pubsub_numsub(feed.channel())[0][1] >= 1, timeout=5)
    monkeypatch.setattr(store, "aget_many", read_then_a_newer_value_arrives)
    await communicator.send_json_to({"action": "watch", "keys": ["nav_goal"]})
    seen = [(await receive_until(communicator, lambda f: f["kind"] == "update"))["msg"]]
    while seen[-1] != {"x": "live"}:  # the live value comes back through Redis after the read
        seen.append((await receive_until(communicator, lambda f: f["kind"] == "update"))["msg"])
    # The page ends on the newest value: the older stored one never arrives after it.
    assert not communicator.__dict__.get("_unbatched") and await communicator.receive_nothing(timeout=0.5)
    assert seen in ([{"x": "live"}], [{"x": "stored"}, {"x": "live"}])
    await communicator.disconnect()


class FakeWriter:
    """A connection taking pre-encoded frames (server.patches.direct_frames.FrameWriter's face)."""

    def __init__(self) -> None:
        self.frames: list[bytes] = []
        self.pending_bytes = 0  # what the kernel has not taken yet; -1: closing

    def write(self, frame: bytes) -> bool:
        self.frames.append(frame)
        return True

    def backlog(self) -> int:
        return self.pending_bytes

    def updates(self) -> list[dict]:
        return [u for f in self.frames for u in decode_frame(f).get("updates", [])]


def decode_frame(frame: bytes) -> dict:
    """Parse a server frame with the websockets library's own protocol (an independent decoder)."""
    from websockets.protocol import Protocol, Side, State

    protocol = Protocol(Side.CLIENT, state=State.OPEN, max_size=None)
    protocol.receive_data(frame)
    (received,) = protocol.events_received()
    assert received.fin
    return json.loads(received.data)


@pytest.mark.parametrize("size", [10, 200, 70_000])
def test_an_encoded_frame_is_a_valid_websocket_text_frame_at_every_length_form(size):
    text = json.dumps({"kind": "updates", "updates": [{"key": "rosout", "msg": {"data": "é" * size}}]})
    assert decode_frame(frames.ws_text_frame(text)) == json.loads(text)


async def test_sockets_with_the_same_updates_share_one_encoded_frame():
    hub = Hub(asyncio.get_running_loop())
    writers = [FakeWriter() for _ in range(3)]
    sockets = [hub.attach(Recorder().send, writer) for writer in writers]
    for socket in sockets:
        hub.watch(socket, ["odom"])
    hub.watch(sockets[2], ["battery_soc"])
    hub.publish("odom", fragment("odom", 1, 1), 1)
    hub.publish("battery_soc", fragment("battery_soc", 0.5, 2), 2)
    await async_wait_until(lambda: all(w.frames for w in writers))
    assert writers[0].frames[0] is writers[1].frames[0]  # encoded once for both
    assert [u["key"] for u in writers[2].updates()] == ["odom", "battery_soc"]
    assert [u["msg"]["data"] for u in writers[0].updates()] == [1]


async def test_a_socket_the_kernel_has_not_drained_gets_the_newest_value_later_and_others_go_on():
    hub = Hub(asyncio.get_running_loop(), tick_s=0.02)
    slow, fast = FakeWriter(), FakeWriter()
    slow.pending_bytes = 4096
    for writer in (slow, fast):
        hub.watch(hub.attach(Recorder().send, writer), ["odom"])
    for i in range(5):
        hub.publish("odom", fragment("odom", i, i), i)
        await async_wait_until(lambda i=i: fast.updates() and fast.updates()[-1]["msg"]["data"] == i)
    assert not slow.frames
    slow.pending_bytes = 0
    await async_wait_until(lambda: slow.frames)
    assert [u["msg"]["data"] for u in slow.updates()] == [4]  # only the newest, once


async def test_a_closing_connection_is_not_written_to():
    hub = Hub(asyncio.get_running_loop())
    closing, open_ = FakeWriter(), FakeWriter()
    closing.pending_bytes = -1
    for writer in (closing, open_):
        hub.watch(hub.attach(Recorder().send, writer), ["odom"])
    hub.publish("odom", fragment("odom", 1, 1), 1)
    await async_wait_until(lambda: open_.frames)
    await asyncio.sleep(0.1)
    assert not closing.frames and not hub._dirty


async def test_a_flood_of_updates_is_paced_to_about_one_frame_per_tick():
    from robot.live.hub import BURST

    hub = Hub(asyncio.get_running_loop(), tick_s=0.05)
    writer = FakeWriter()
    hub.watch(hub.attach(Recorder().send, writer), ["odom"])
    loop = asyncio.get_running_loop()
    start = loop.time()
    i = 0
    while loop.time() - start < 0.5:
        hub.publish("odom", fragment("odom", i, i), i)
        i += 1
        await asyncio.sleep(0.002)
    elapsed = loop.time() - start
    await async_wait_until(lambda: writer.updates() and writer.updates()[-1]["msg"]["data"] == i - 1)
    # A burst of BURST frames, then one per tick however fast the updates come (a slow machine
    # only makes fewer frames); the newest value always arrives.
    assert len(writer.frames) <= BURST + elapsed / 0.05 + 2
    assert i > len(writer.frames)


async def test_a_lone_update_is_written_within_a_few_loop_turns_without_waiting_for_a_timer():
    from robot.live.hub import FLUSH_TURNS

    hub = Hub(asyncio.get_running_loop(), tick_s=10.0)  # any wait for a tick or a timer would show
    writer = FakeWriter()
    hub.watch(hub.attach(Recorder().send, writer), ["odom"])
    hub.publish("odom", fragment("odom", 1, 1), 1)
    assert not writer.frames  # not inside publish: what the loop reads meanwhile may join it
    for _ in range(FLUSH_TURNS):
        await asyncio.sleep(0)
    assert [u["msg"]["data"] for u in writer.updates()] == [1]


async def test_an_update_that_arrives_while_the_loop_reads_joins_the_frame_of_the_one_before():
    # The pose, then the odometry a moment later in a read of its own, through the link's coalescer task.
    hub = Hub(asyncio.get_running_loop(), tick_s=10.0)
    writer = FakeWriter()
    hub.watch(hub.attach(Recorder().send, writer), ["odom", "robot_pose"])
    hub.publish("robot_pose", fragment("robot_pose", 1, 1), 1)
    loop = asyncio.get_running_loop()

    def read_odom() -> None:  # a read callback: the coalescer's task publishes a turn later
        loop.call_soon(hub.publish, "odom", fragment("odom", 2, 2), 2)

    loop.call_soon(read_odom)
    await async_wait_until(lambda: writer.frames)
    await asyncio.sleep(0.05)
    assert len(writer.frames) == 1
    assert [u["key"] for u in writer.updates()] == ["robot_pose", "odom"]


async def test_updates_offered_in_one_loop_turn_share_one_frame():
    hub = Hub(asyncio.get_running_loop())
    writer = FakeWriter()
    hub.watch(hub.attach(Recorder().send, writer), ["odom", "robot_pose", "battery_soc"])
    hub.publish("robot_pose", fragment("robot_pose", 1, 1), 1)
    hub.publish("odom", fragment("odom", 2, 2), 2)
    hub.publish("odom", fragment("odom", 3, 3), 3)
    await async_wait_until(lambda: writer.frames)
    await asyncio.sleep(0.05)
    assert len(writer.frames) == 1
    assert [(u["key"], u["msg"]["data"]) for u in writer.updates()] == [("robot_pose", 1), ("odom", 3)]


async def test_the_services_a_process_cannot_reach_ride_on_every_status_frame():
    hub = Hub(asyncio.get_running_loop(), tick_s=0.01)
    recorder = Recorder()
    hub.attach(recorder.send)
    link_status = frames.status_text({"connected": True, "link_running": True, "url": "ws://robot"})
    hub.publish_status(link_status)
    await async_wait_until(lambda: recorder.frames)
    assert "services_down" not in recorder.frames[-1]

    hub.set_services({"redis": "Redis is unreachable"})
    await async_wait_until(lambda: len(recorder.frames) == 2)
    assert recorder.frames[-1]["services_down"] == {"redis": "Redis is unreachable"}
    # The link's last word, with what this process sees.
    assert {k: v for k, v in recorder.frames[-1].items() if k != "services_down"} == json.loads(link_status)
    hub.set_services({"redis": "Redis is unreachable"})  # unchanged: no frame
    hub.publish_status(frames.status_text({"connected": False, "url": "ws://other"}))
    await async_wait_until(lambda: len(recorder.frames) == 3)
    assert recorder.frames[-1]["services_down"] and recorder.frames[-1]["url"] == "ws://other"
    hub.set_services({})
    await async_wait_until(lambda: len(recorder.frames) == 4)
    assert "services_down" not in recorder.frames[-1]
