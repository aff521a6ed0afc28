"""The robot link against the simulator: real websocket, unmodified roslibpy."""

import asyncio
import contextlib
import threading

import pytest

from robot import interface as ri
from robot import supervisor
from robot.link import subscriptions
from robot.link.bus import RobotOffline, apublish, arequest
from robot.live.state import link_status
from tests.helpers import async_wait_until, receive_frame, receive_until, ws_communicator

BATTERY = "battery_soc"


async def watch(user, *keys):
    communicator = ws_communicator(user)
    connected, _ = await communicator.connect(timeout=10)
    assert connected
    await communicator.send_json_to({"action": "watch", "keys": list(keys)})
    return communicator


async def test_it_delivers_robot_updates_to_a_browser_consumer(link, sim, viewer):
    communicator = await watch(viewer, BATTERY)
    frame = await receive_until(communicator, lambda f: f["kind"] == "update" and f["key"] == BATTERY, timeout=10)
    assert 0.0 <= frame["msg"]["data"] <= 1.0
    # (The first status frame may be from before the link's first connection, when this test runs first.)
    await receive_until(communicator, lambda f: f["kind"] == "status" and f["connected"] is True, timeout=5)
    await communicator.disconnect()


async def test_it_subscribes_upstream_once_however_many_browsers_watch(link, sim, viewer):
    communicators = [await watch(viewer, BATTERY, "robot_pose") for _ in range(5)]
    for communicator in communicators:
        await receive_until(communicator, lambda f: f["kind"] == "update" and f["key"] == "robot_pose", timeout=10)
    for key in (BATTERY, "robot_pose", "rosout"):
        assert sim.robot.subscription_count(ri.topic(key).name) == 1, key
    for communicator in communicators:
        await communicator.disconnect()


async def test_it_coalesces_high_rate_topics_for_browsers(link, sim, viewer):
    communicator = await watch(viewer, "tf")
    loop = asyncio.get_running_loop()
    start = loop.time()
    arrivals = []
    while loop.time() - start < 2.0:
        frame = await receive_frame(communicator, timeout=3)
        if frame["kind"] == "update" and frame["key"] == "tf":
            arrivals.append(loop.time())
    # /tf is published at ~50 Hz, far faster than its 5 Hz UI rate: about 5 frames a second over the
    # span they arrived in (one more for the first, two for ticks that a busy loop delayed).
    assert len(arrivals) >= 3
    assert len(arrivals) <= 5 * (arrivals[-1] - arrivals[0]) + 3, arrivals
    await communicator.disconnect()


async def test_it_shows_offline_and_resubscribes_when_the_robot_returns(link, sim, viewer):
    from simulator.harness import SimThread

    communicator = await watch(viewer, BATTERY)
    await receive_until(communicator, lambda f: f["kind"] == "update", timeout=10)
    port = sim.port
    await asyncio.get_running_loop().run_in_executor(None, sim.stop)
    down = await receive_until(communicator, lambda f: f["kind"] == "status" and not f["connected"], timeout=10)
    assert down["connected"] is False
    with pytest.raises(RobotOffline):
        await apublish("register_event", {"data": "aborted"})

    revived = SimThread(port=port, video_port=0, startup_s=0.5)
    await asyncio.get_running_loop().run_in_executor(None, revived.start)
    try:
        await receive_until(communicator, lambda f: f["kind"] == "status" and f["connected"], timeout=15)
        # roslibpy subscribes again a moment after the reconnect; an update queued before the drop may come first.
        await async_wait_until(lambda: revived.robot.subscription_count(ri.topic(BATTERY).name) == 1, timeout=10,
                               what="the battery subscription renewed")
        frame = await receive_until(communicator, lambda f: f["kind"] == "update" and f["key"] == BATTERY, timeout=10)
        assert frame["msg"]["data"] >= 0
        assert revived.robot.subscription_count(ri.topic(BATTERY).name) == 1
        # The refused command was not queued to fire after the reconnect.
        await asyncio.sleep(0.5)
        assert revived.robot.received_count(ri.topic("register_event").name) == 0
    finally:
        await communicator.disconnect()
        await asyncio.get_running_loop().run_in_executor(None, revived.stop)


async def test_it_relays_requests_over_the_channel_layer(link, sim):
    # As a web process does when the link runs elsewhere (REDIS_URL): no hosted link here.
    supervisor.release(link)
    try:
        await arequest("publish", topic=ri.topic("register_event").name, msg_type="std_msgs/String",
                       msg={"data": "aborted"})
    finally:
        supervisor.hold(link)
    await async_wait_until(lambda: sim.robot.received_count(ri.topic("register_event").name) == 1, timeout=5)


async def test_it_drops_requests_that_reach_the_link_after_their_deadline(link, sim):
    import time

    reply = await link.requests.execute({"op": "publish", "topic": "/x", "msg_type": "std_msgs/String", "msg": {}})
    assert reply["ok"] is True  # sanity: executes when on time
    await link.requests.handle({"op": "publish", "topic": ri.topic("register_event").name,
                                "msg_type": "std_msgs/String", "msg": {"data": "late"}, "deadline": time.time() - 1})
    await asyncio.sleep(0.3)
    assert sim.robot.received_count(ri.topic("register_event").name) == 0


@pytest.mark.django_db(transaction=True)
async def test_it_lets_operators_but_not_viewers_reconnect_at_most_every_few_seconds_audited(
        link, sim, viewer, operator):
    from robot.models import AuditEntry

    as_viewer = await watch(viewer)
    await as_viewer.send_json_to({"action": "reconnect"})
    refused = await receive_until(as_viewer, lambda f: f["kind"] == "error")
    assert "operators" in refused["message"]
    as_operator = await watch(operator)
    await as_operator.send_json_to({"action": "reconnect"})
    await receive_until(as_operator, lambda f: f["kind"] == "notice")
    await receive_until(as_operator, lambda f: f["kind"] == "status" and f["connected"], timeout=10)
    since = link.dial.since
    await as_operator.send_json_to({"action": "reconnect"})  # a page's button pressed again at once
    again = await receive_until(as_operator, lambda f: f["kind"] == "error")
    assert again["message"].startswith("The robot link reconnected moments ago; try again in ")
    await asyncio.sleep(0.5)
    assert link.connected and link.dial.since == since  # the second press did not drop the connection
    rows = [(e.username, e.action, e.ok, e.error_code) async for e in AuditEntry.objects.order_by("id")]
    assert rows == [("vera", "link.reconnect", False, "forbidden"), ("otto", "link.reconnect", True, ""),
                    ("otto", "link.reconnect", False, "throttled")]
    await as_viewer.disconnect()
    await as_operator.disconnect()


async def test_it_refuses_to_watch_unknown_or_bulky_topics(link, viewer):
    communicator = await watch(viewer, "map", "no_such_key")
    frame = await receive_until(communicator, lambda f: f["kind"] == "error")
    assert "map" in frame["message"] and "no_such_key" in frame["message"]
    await communicator.disconnect()


async def test_it_replays_recent_log_lines_to_a_page_opened_later(link, sim, viewer):
    from robot.live.state import get_store

    loop = asyncio.get_running_loop()
    for i in range(3):
        await loop.run_in_executor(None, sim.call, lambda i=i: sim.robot.bus.rosout(8, "/cyborg_test", f"boom {i}"))

    async def stored():
        return [e["msg"]["msg"] for e in await get_store().aget_recent("rosout")]

    deadline = loop.time() + 5
    while "boom 2" not in await stored():
        assert loop.time() < deadline, "the link never stored the log lines"
        await asyncio.sleep(0.05)
    communicator = await watch(viewer, "rosout")
    seen = []
    while "boom 2" not in seen:
        frame = await receive_until(communicator, lambda f: f["kind"] == "update" and f["key"] == "rosout")
        seen.append(frame["msg"]["msg"])
    assert [m for m in seen if m.startswith("boom")] == ["boom 0", "boom 1", "boom 2"]
    await communicator.disconnect()


async def test_it_turns_nagle_off_on_the_rosbridge_socket(link):
    import socket

    handle = link.dial.ros.factory._proto.transport.getHandle()
    # With Nagle on, small command frames wait ~30-40 ms for the robot's delayed ACK.
    assert handle.getsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY) != 0


async def test_a_subscription_the_robot_refuses_is_reported_and_tried_again_on_every_reconnect(link, sim):
    link.subscriptions.subscribe("/lidar/points", "velodyne_msgs/VelodyneScan")  # a package the robot does not have

    await async_wait_until(lambda: "/lidar/points" in link.subscriptions.failed, timeout=10, what="the refusal")
    assert "velodyne_msgs" in link.subscriptions.failed["/lidar/points"]
    assert "/lidar/points" in link.upkeep.status()["failed_subscriptions"]
    # What /healthz lists (dashboard.health reads the link's status from the store).
    await async_wait_until(lambda: "/lidar/points" in (link_status().get("failed_subscriptions") or {}),
                           timeout=5, what="the refusal in the stored link status")

    before = link.dial.since
    link.dial.reconnect()
    await async_wait_until(lambda: link.dial.since > before and "/lidar/points" in link.subscriptions.failed,
                           timeout=15, what="the subscription tried (and refused) again after the reconnect")


async def test_a_message_read_on_the_loops_own_thread_is_handled_in_that_read(link, monkeypatch, caplog):
    # Inside Daphne the reactor is the event loop's thread: no hop through call_soon_threadsafe.
    seen = []
    link.listeners.append(lambda name, msg_type, msg, t: seen.append((name, threading.get_ident())))
    link.subscriptions.received("/not_in_the_registry", "std_msgs/String", {"data": "x"})
    assert ("/not_in_the_registry", threading.get_ident()) in seen

    def broken(topic, msg, t):
        raise ValueError("bad message")

    monkeypatch.setitem(subscriptions._handlers, BATTERY, broken)
    link.subscriptions.received(ri.topic(BATTERY).name, ri.topic(BATTERY).type, {"data": 0.5})  # logged, never raised
    assert "handling a message on /" in caplog.text


async def test_a_message_read_on_another_thread_is_handled_on_the_loop(link):
    seen = []
    link.listeners.append(lambda name, msg_type, msg, t: seen.append((name, threading.get_ident())))
    reader = threading.Thread(target=link.subscriptions.received, args=("/not_in_the_registry", "std_msgs/String", {}))
    reader.start()
    reader.join()
    await async_wait_until(lambda: ("/not_in_the_registry", threading.get_ident()) in seen)
    assert [ident for name, ident in seen if name == "/not_in_the_registry"] == [threading.get_ident()]


async def test_it_stops_cleanly_when_its_request_loop_was_cancelled(link, sim):
    """A Redis freeze once left the request loop cancelled, and the stop then ended on its
    CancelledError: the link process exited without zeroing, closing or handing back its lease."""
    link.requests.serving.cancel()
    with contextlib.suppress(asyncio.CancelledError):
        await link.requests.serving
    await asyncio.wait_for(link.stop(), 10)  # returns, and raises nothing
    assert link.dial.ros is None and not link.connected


class _SlowThenFastLease:
    """A lease whose fencing check answers the first publish last (two pooled Redis connections)."""

    held = may_stop = True

    def __init__(self) -> None:
        self.checks = 0

    async def check(self) -> bool:
        self.checks += 1
        await asyncio.sleep(0.1 if self.checks == 1 else 0)
        return True


async def test_publishes_reach_the_robot_in_the_order_they_came_whatever_the_fencing_check_takes(link, sim):
    cmd_vel = ri.topic("cmd_vel")
    moving = {"linear": {"x": 0.5, "y": 0.0, "z": 0.0}, "angular": {"x": 0.0, "y": 0.0, "z": 0.0}}
    zero = {"linear": {"x": 0.0, "y": 0.0, "z": 0.0}, "angular": {"x": 0.0, "y": 0.0, "z": 0.0}}
    link.requests.lease = _SlowThenFastLease()
    try:
        before = sim.robot.received_count(cmd_vel.name)
        replies = await asyncio.gather(*(
            link.requests.execute({"op": "publish", "topic": cmd_vel.name, "msg_type": cmd_vel.type,
                                   "msg": msg, "fresh_press": True}) for msg in (moving, zero)))
        assert all(r["ok"] for r in replies), replies
        await async_wait_until(lambda: sim.robot.received_count(cmd_vel.name) == before + 2, timeout=5)
    finally:
        link.requests.lease = None
    assert ri.is_zero_twist(sim.received(cmd_vel.name)[-1])  # the driver's zero came last, as sent
