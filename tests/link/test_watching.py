"""Any topic a page opens, against the simulator: one upstream subscription, leases, grace, echo."""

import asyncio

import pytest

from robot import interface as ri
from robot import supervisor
from robot.link import holders
from robot.link.topicwatch import LocalWatches, TopicRefused
from robot.link.watching import echo_key, watches_of
from tests.helpers import async_wait_until, receive_frame, receive_until, ws_communicator

TF = ri.topic("tf").name  # in the registry, but nothing subscribes to it until someone watches
ROSOUT = ri.topic("rosout").name


async def open_topic(user, name):
    communicator = ws_communicator(user)
    connected, _ = await communicator.connect(timeout=10)
    assert connected
    await communicator.send_json_to({"action": "watch_topic", "topic": name})
    return communicator


def is_echo(name):
    return lambda f: f["kind"] == "update" and f["key"] == echo_key(name)


async def test_pages_watching_a_topic_share_one_upstream_subscription(link, sim, viewer, settings):
    settings.TOPICS_IDLE_GRACE_S = 60
    assert sim.subscription_count(TF) == 0
    pages = [await open_topic(viewer, TF) for _ in range(4)]
    for page in pages:
        frame = await receive_until(page, is_echo(TF), timeout=10)
        assert frame["msg"]["transforms"][0]["header"]["frame_id"]
    assert sim.subscription_count(TF) == 1
    for page in pages:
        await page.disconnect()
    # Within the grace period the subscription stays (a page reopened soon finds it warm).
    await asyncio.sleep(0.5)
    assert sim.subscription_count(TF) == 1
    settings.TOPICS_IDLE_GRACE_S = 0
    await async_wait_until(lambda: sim.subscription_count(TF) == 0, timeout=10, what="unsubscribed after the grace")


async def test_a_topic_left_alone_is_unsubscribed_after_the_grace_period(link, sim, viewer, settings):
    settings.TOPICS_IDLE_GRACE_S = 0.3
    page = await open_topic(viewer, TF)
    await receive_until(page, is_echo(TF), timeout=10)
    await page.send_json_to({"action": "unwatch_topic", "topic": TF})
    await async_wait_until(lambda: sim.subscription_count(TF) == 0, timeout=10, what="unsubscribed")
    await page.disconnect()


async def test_registry_and_recorded_topics_stay_subscribed_when_nobody_watches(link, sim, viewer, settings):
    settings.TOPICS_IDLE_GRACE_S = 0
    sonar = ri.topic("sonar")
    link.subscriptions.subscribe(sonar.name, sonar.type, holder="recorder")  # as the recorder does for a recorded topic
    for name in (ROSOUT, sonar.name):
        page = await open_topic(viewer, name)
        await receive_until(page, is_echo(name), timeout=15)
        await page.disconnect()
    await async_wait_until(lambda: not watches_of(link).idle_since and not watches_of(link).leases, timeout=10,
                           what="the grace period over")
    assert sim.subscription_count(ROSOUT) == 1  # the registry's own
    assert sim.subscription_count(sonar.name) == 1  # the recorder's
    link.subscriptions.unsubscribe(sonar.name, holder="recorder")
    await async_wait_until(lambda: sim.subscription_count(sonar.name) == 0, timeout=10, what="recorder let go")


async def test_a_dead_web_process_lease_runs_out(link, sim, settings, monkeypatch):
    settings.TOPICS_IDLE_GRACE_S = 0
    monkeypatch.setattr(holders, "LEASE_S", 0.5)
    reply = await link.requests.execute({"op": "topics_watch", "holder": "gone-process", "topics": [TF]})
    assert reply == {"ok": True, "refused": {}}
    await async_wait_until(lambda: sim.subscription_count(TF) == 1, timeout=10, what="subscribed")
    # Nobody renews: the lease expires, then the subscription goes.
    await async_wait_until(lambda: sim.subscription_count(TF) == 0, timeout=10, what="lease expired")


async def test_watches_from_several_web_processes_are_counted_at_the_link(link, sim, settings):
    settings.TOPICS_IDLE_GRACE_S = 0
    supervisor.release(link)  # requests travel over the channel layer, as from another process
    try:
        first, second = LocalWatches(), LocalWatches()
        await first.watch("page-a", TF)
        await second.watch("page-b", TF)
        await second.watch("page-c", TF)
        await async_wait_until(lambda: sim.subscription_count(TF) == 1, timeout=10, what="subscribed")
        assert watches_of(link).leases.holders(TF) == {first.holder, second.holder}
        await first.drop("page-a")
        await second.unwatch("page-b", TF)
        await asyncio.sleep(0.3)
        assert sim.subscription_count(TF) == 1  # page-c in the second process still watches
        await second.drop("page-c")
        await async_wait_until(lambda: sim.subscription_count(TF) == 0, timeout=10, what="unsubscribed")
    finally:
        supervisor.hold(link)


async def test_unknown_topics_and_bad_names_get_a_clear_error_and_never_reach_the_robot(link, sim, viewer):
    page = await open_topic(viewer, "/no/such_topic")
    error = await receive_until(page, lambda f: f["kind"] == "error", timeout=10)
    assert error["code"] == "not_found" and "/no/such_topic" in error["message"]
    for bad in ("no_slash", "/9lives", "/a b", "", 42, "/x" * 200):
        await page.send_json_to({"action": "watch_topic", "topic": bad})
        error = await receive_until(page, lambda f: f["kind"] == "error", timeout=5)
        assert error["code"] == "invalid", bad
    assert sim.subscription_count("/no/such_topic") == 0
    assert not watches_of(link).leases
    await page.disconnect()
    with pytest.raises(TopicRefused):
        await LocalWatches().watch("someone", "/no/such_topic")


async def test_sound_is_never_echoed_on_the_topics_page_nor_watched_as_a_key(link, sim, viewer, operator):
    """Listening goes through the audio socket (operators, audited); the topics page once gave a
    viewer the start of every microphone chunk."""
    for user in (viewer, operator):
        for name in (ri.topic("audio").name, ri.topic("speaker").name):
            page = await open_topic(user, name)
            error = await receive_until(page, lambda f: f["kind"] == "error", timeout=10)
            # a viewer: for operators only (the web process); an operator: listen on the audio socket (the link)
            reason = "operators only" if user is viewer else "carries sound"
            assert error["code"] == "forbidden" and reason in error["message"], error
            await page.send_json_to({"action": "watch", "keys": ["audio", "speaker"]})
            error = await receive_until(page, lambda f: f["kind"] == "error", timeout=5)
            assert "audio" in error["message"] and "speaker" in error["message"]
            await page.disconnect()
    await asyncio.sleep(0.3)
    assert sim.subscription_count(ri.topic("audio").name) == 0
    assert not watches_of(link).leases


async def test_large_messages_are_summarised(link, sim, viewer):
    page = await open_topic(viewer, ri.topic("map").name)
    frame = await receive_until(page, is_echo(ri.topic("map").name), timeout=15)
    info, data = frame["msg"]["info"], frame["msg"]["data"]
    assert data["_truncated"] == "array"
    assert data["length"] == info["width"] * info["height"] > 1000
    assert len(data["items"]) < 20
    await page.disconnect()


async def test_it_lists_the_robots_topics_and_measures_a_rate(link, sim):
    reply = await link.requests.execute({"op": "topics_list"})
    assert reply["ok"], reply
    topics = {t["name"]: t for t in reply["values"]}
    assert topics[ROSOUT]["type"] == "rosgraph_msgs/Log"
    assert topics[ROSOUT]["subscribed"] is True
    assert "/rosbridge_websocket" in topics[ROSOUT]["publishers"]
    assert topics[ri.topic("battery_soc").name]["publishers"] == ["/RosAria"]
    assert topics[TF]["subscribed"] is False
    rate = await link.requests.execute({"op": "topics_rate", "topic": ri.topic("robot_pose").name, "window_s": 2})
    assert rate["ok"], rate
    assert 5 <= rate["values"]["hz"] <= 15  # the simulator publishes the pose at 10 Hz
    missing = await link.requests.execute({"op": "topics_rate", "topic": "/no/such_topic", "window_s": 1})
    assert missing["ok"] is False and missing["error_code"] == "not_found"


async def test_a_fast_topic_reaches_pages_at_most_at_the_echo_rate(link, sim, viewer, settings):
    settings.TOPICS_ECHO_MAX_HZ = 5  # /tf comes at 25 Hz
    page = await open_topic(viewer, TF)
    await receive_until(page, is_echo(TF), timeout=10)
    loop = asyncio.get_running_loop()
    start, count = loop.time(), 0
    while loop.time() - start < 2.0:
        frame = await receive_frame(page, timeout=3)
        count += is_echo(TF)(frame)
    assert 4 <= count <= 14
    await page.disconnect()
