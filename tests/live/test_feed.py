"""Each web process's one Redis subscription feeds its hub. A page is subscribed
before it reads its first snapshot, and nothing published while the subscription was down is lost."""


from robot.live import feed, redis_clients
from robot.live.announce import aannounce, server_update
from robot.live.hub import get_hub
from tests.helpers import async_wait_until, receive_until, ws_communicator


async def _open(user, keys):
    page = ws_communicator(user)
    assert (await page.connect(timeout=10))[0]
    await page.send_json_to({"action": "watch", "keys": keys})
    await async_wait_until(lambda: all(get_hub()._watchers.get(k) for k in keys), timeout=5, what="watching")
    return page


async def test_the_process_is_subscribed_by_the_time_a_page_is_open(viewer):
    page = ws_communicator(viewer)
    assert (await page.connect(timeout=10))[0]
    await receive_until(page, lambda f: f["kind"] == "status")
    client = redis_clients.new_aclient()
    try:
        [(_, subscribers)] = await client.pubsub_numsub(feed.channel())
    finally:
        await client.aclose()
    assert subscribers >= 1
    await page.disconnect()


async def test_what_was_published_while_the_subscription_was_down_still_reaches_the_page(viewer):
    page = await _open(viewer, ["nav_goal", "rosout"])
    await aannounce("rosout", dict(server_update("rosout", {"msg": "before"})))
    await receive_until(page, lambda f: f.get("key") == "rosout")
    client = redis_clients.new_aclient()
    try:
        ours = [c for c in await client.client_list() if c.get("name") == feed.SUBSCRIBER_NAME]
        assert ours
        for connection in ours:
            await client.client_kill_filter(_id=connection["id"])
    finally:
        await client.aclose()
    # Published to nobody: the subscription is gone and comes back only after a retry.
    await aannounce("nav_goal", dict(server_update("nav_goal", {"x": 7})))
    await aannounce("rosout", dict(server_update("rosout", {"msg": "during"})))
    seen: list[dict] = []

    def both(frame: dict) -> bool:
        seen.append(frame)
        keys = {f.get("key") for f in seen}
        return {"nav_goal", "rosout"} <= keys

    await receive_until(page, both, timeout=10)
    assert [f["msg"] for f in seen if f.get("key") == "nav_goal"] == [{"x": 7}]
    # An event-like key gets the line it missed, never again the one it had.
    assert [f["msg"]["msg"] for f in seen if f.get("key") == "rosout"] == ["during"]
    await page.disconnect()
